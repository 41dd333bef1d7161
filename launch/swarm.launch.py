"""A whole swarm: world, monitor, recorder and the robots, as ``scripts/run_swarm.sh`` runs it.

    ros2 launch phd_swarm swarm.launch.py config:=dames_static.yaml robots:=4 seed:=3

Arguments (``ros2 launch phd_swarm swarm.launch.py --show-args``): ``config`` (a path, or
the name of a file of ``share/phd_swarm/config/``), ``robots``, ``targets``, ``duration``,
``seed``, ``controller``, ``realtime``, ``record``, ``record_inboxes``,
``robots_per_process``, ``dds``, ``discovery_server``, ``out`` and ``name``; the defaults are
the config's and ``run_swarm.sh``'s.

The nodes, their parameters and their environment are the plan ``run_swarm.sh`` starts
(``phd_swarm.tools.launch_plan.swarm_plan``): the resolved config in
``<out>/<name>/config.yaml``; ``/recorder`` and ``/monitor`` first, then ``/robot_<i>/robot``
(each robot in its own namespace, the nav2 multi-robot pattern; with
``robots_per_process:=P`` P robot nodes per ``team`` process) and ``/world``; DDS on
loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, or the repository's Fast DDS profile
and a discovery server on 127.0.0.1 above 30 processes) and ``ROS_DOMAIN_ID`` 42 unless the
caller exported one. The topics are those the system's parts declare; nothing here lists
them. The run ends when the monitor has written ``summary.json``; Ctrl-C stops every node
(the recorder closes ``run.mcap``).

Unlike ``run_swarm.sh``, the robot processes all start at once (no start window), none is
forked from a fork server, and their output goes to the launch log (``~/.ros/log``) rather
than ``<out>/<name>/logs/``: for teams of more than ~30 robot processes on a small machine,
use ``run_swarm.sh`` (docs/deployment.md).
"""

from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.launch_description import LaunchDescription

from phd_swarm.tools.launch_actions import SWARM_ARGUMENTS, swarm_launch


def generate_launch_description() -> LaunchDescription:
    """The arguments, then the run they describe (resolved when the launch starts)."""
    arguments = [DeclareLaunchArgument(name, description=text)
                 if default is None else
                 DeclareLaunchArgument(name, default_value=default, description=text)
                 for name, (default, text) in SWARM_ARGUMENTS.items()]
    return LaunchDescription([*arguments, OpaqueFunction(function=swarm_launch)])
