"""The parameters of every phd_swarm node: name, default, description, range (rclpy-free).

Nodes declare these with :func:`phd_swarm.nodes.ros_params.declare` (type, description and range
become the ROS parameter descriptor, so ``ros2 param describe`` shows them); the run-config
loader (:mod:`phd_swarm.config`) checks a YAML file against the same table before any process
starts, so a typo or an out-of-range value fails fast with the file and key in the message.
The scenario itself is declared as read-only ``scenario.*`` parameters on every node
(:mod:`phd_swarm.config`).
"""

from __future__ import annotations

from phd_swarm.core.params import ParamSpec

#: Parameters every node has (the ``/**`` block of a config file), besides ``scenario.*``.
SHARED = (
    ParamSpec("world_frame_id", "map", "Frame id of the world (REP 105) in every header."),
    ParamSpec("auth_key_file", "", "The run's key (hex, a file only its user can read): the "
              "world and the robots sign what steers a robot with it and reject what is not "
              "signed ('' for none; run_swarm.sh makes one per run)."),
)

WORLD = (
    ParamSpec("mode", "lockstep", "lockstep: step k+1 starts when every live robot reported "
              "step k (or timed out); realtime: steps at a fixed rate regardless.",
              choices=("lockstep", "realtime")),
    ParamSpec("step_timeout", 15.0, "Lockstep: wall seconds without any word from a robot "
              "(report or keep-alive status) before it counts as dead; at least 3 robot "
              "tick_period s [s].", low=0.1, high=3600.0),
    ParamSpec("ready_timeout", 60.0, "Start-up: wall seconds without a new robot (or "
              "observer) becoming ready after which the world gives up and exits with an "
              "error, without running a step [s].", low=0.1, high=3600.0),
    ParamSpec("observers", 0, "Number of observer nodes (monitor, recorder) that must have "
              "matched /world/truth before step 0.", low=0, high=64),
    ParamSpec("realtime_factor", 1.0, "Realtime: sim seconds per wall second.",
              low=0.01, high=1000.0),
    ParamSpec("publish_markers", True, "Publish /world/markers (robots, fields of view, "
              "targets)."),
    ParamSpec("linger", 1.0, "Wall seconds to keep publishing after the last step so "
              "observers receive it [s].", low=0.0, high=60.0),
)

ROBOT = (
    ParamSpec("robot_id", -1, "Id of this robot in the team (0..robots-1); required.",
              low=-1, high=1_000_000),
    ParamSpec("tick_period", 1.0, "Wall seconds without a new protocol message after which "
              "one timeout round passes, and a waiting robot sends a keep-alive; also the "
              "period of its WORKING status to the world while a step lasts or it waits for the "
              "next one [s].",
              low=0.01, high=600.0),
    ParamSpec("timeout_ticks", 5, "Rounds without an answer before an awaited peer not "
              "heard from in that time (keep-alives included) is declared dead.", low=1,
              high=1000),
    ParamSpec("revive_every", 1, "Real time: a peer this robot declared dead on silence is "
              "admitted again (if the world says it is alive) only at steps k with k mod "
              "revive_every = 0, the same for every robot; the world's own verdicts count at "
              "once. run_swarm sets the world's step_timeout in steps in real time; 1: every "
              "step (lockstep's rule).", low=1, high=1_000_000),
    ParamSpec("observers", 0, "Number of observers that must have matched this robot's "
              "status topic before it reports ready.", low=0, high=64),
    ParamSpec("ready_timeout", 60.0, "Wall seconds to wait for the team state and the "
              "observers before giving up [s].", low=0.1, high=3600.0),
    ParamSpec("publish_density", True, "Publish the local PHD window on density and "
              "density_grid (the monitor needs it)."),
    ParamSpec("max_measurements", 10000, "Measurement sets with more entries are rejected "
              "as absurd.", low=1, high=10_000_000),
    ParamSpec("fault_drop", 0.0, "Fault injection: probability that a protocol message this "
              "robot sends is lost (phd_swarm.core.exchange.faults, as in the in-memory "
              "engine).", low=0.0, high=1.0),
    ParamSpec("fault_delay", 0.0, "Fault injection: probability that a protocol message not "
              "lost is held back 1..fault_delay_rounds tick periods.", low=0.0, high=1.0),
    ParamSpec("fault_delay_rounds", 1, "Fault injection: most tick periods a delayed message "
              "is held back.", low=1, high=1000),
    ParamSpec("fault_seed", 0, "Fault injection: seed of the robots' fault generators "
              "(default_rng([fault_seed, robot_id])).", low=0, high=2**31 - 1),
)

MONITOR = (
    ParamSpec("summary_path", "", "Where to write summary.json at the end ('' for none)."),
    ParamSpec("progress_every", 10, "Log a progress line every this many steps (0: never).",
              low=0, high=1_000_000),
    ParamSpec("publish_density", True, "Publish the team PHD on /monitor/density and "
              "/monitor/density_grid."),
    ParamSpec("publish_markers", True, "Publish /monitor/markers (cells, goals, estimates; "
              "grid nodes and meetings of a walk on a grid)."),
    ParamSpec("exit_when_done", False, "Shut down after the last step of the scenario."),
    ParamSpec("end_timeout", 30.0, "After the world stops, wall seconds to wait for the last "
              "grids before finishing with what arrived [s].", low=0.0, high=3600.0),
    ParamSpec("verdict_window", 1, "Steps W between a robot's last report and the world's "
              "verdict on it: step k awaits the robots alive at k..k+W (1 in lockstep; "
              "run_swarm and the launch files set it from the world's step_timeout in real "
              "time).", low=1, high=1_000_000),
)

RECORDER = (
    ParamSpec("output", "run.mcap", "Path of the MCAP file to write."),
    ParamSpec("compression", "zstd", "Chunk compression.", choices=("zstd", "lz4", "none")),
    ParamSpec("chunk_size", 1_048_576, "Chunk size [bytes].", low=1024, high=1 << 30),
    ParamSpec("params_file", "", "Resolved run config (ROS parameter file): its scenario "
              "gives the topics to subscribe at start, its text is stored as MCAP metadata."),
    ParamSpec("discover", True, "Also poll the ROS graph and record new phd_swarm topics "
              "(/clock, /world/*, /monitor/*, /robot_*/*) as they appear."),
    ParamSpec("record_inboxes", False, "Also record the protocol traffic (/robot_*/inbox): "
              "~90 % of a run's messages, not needed to re-evaluate or replay the results."),
    ParamSpec("wait_for_world", True, "With params_file: subscribe to /world/truth (which the "
              "world counts to start step 0) only once every other topic the world writes "
              "has matched a writer here, so that the run cannot start before the log can "
              "hold it."),
)

VIEWER = (
    ParamSpec("rerun_url", "", "The Rerun gRPC proxy the view is sent to "
              "(rerun+http://127.0.0.1:PORT/proxy, from scripts/run_swarm.sh --view or "
              "python -m phd_swarm.tools.view_server); '' sends it nowhere."),
    ParamSpec("save_path", "", "Also write the view to this .rrd file ('' for none); "
              "rerun FILE opens it."),
    ParamSpec("recording_name", "phd_swarm", "The recording's name in the viewer."),
    ParamSpec("discover_period", 0.5, "Wall seconds between two looks at the graph for new "
              "topics to draw [s].", low=0.05, high=60.0),
    ParamSpec("trail_steps", 40, "Positions kept in each robot's trail.", low=2,
              high=100_000),
    ParamSpec("observe_world", False, "Be one of the world's observers: read /world/truth "
              "once /world/robots, /world/markers and every other topic drawn have matched "
              "their writer here, so a lockstep world whose observers parameter counts the "
              "viewer starts step 0 only when the view can draw every step (run_swarm.sh "
              "--view sets both)."),
)

#: Node key in a config file -> its parameters.
NODES = {"world": WORLD, "robot": ROBOT, "monitor": MONITOR, "recorder": RECORDER}
