"""One robot, node ``/robot_<id>/robot``, as ``scripts/run_robot.sh`` runs it.

    ros2 launch phd_swarm robot.launch.py robot_id:=3 config:=runs/<run>/config.yaml

It joins the team of the config's world: before step 0 as one of the team, or later,
into a run under way (a robot counted dead rejoins when it is back; docs/ros.md). Give it
the config the team runs with (``run_swarm.sh`` writes it to ``runs/<run>/config.yaml``).
DDS stays on loopback and ``ROS_DOMAIN_ID`` is 42 unless the caller exported others.
"""

from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.launch_description import LaunchDescription
from launch.substitutions import LaunchConfiguration

from phd_swarm.tools.launch_actions import single_node_actions
from phd_swarm.tools.launch_plan import find_config, robot_process


def _robot(context):
    text = LaunchConfiguration("robot_id").perform(context)
    if not text.isdigit():
        raise ValueError(f"launch argument robot_id: a non-negative integer, got {text!r}")
    config = str(find_config(LaunchConfiguration("config").perform(context)))
    return single_node_actions(robot_process(int(text), config), config, context)


def generate_launch_description() -> LaunchDescription:
    """The ``robot_id`` and ``config`` arguments and the robot node."""
    return LaunchDescription([
        DeclareLaunchArgument("robot_id", description="the robot's id, 0..robots-1"),
        DeclareLaunchArgument("config", description="the team's config file: a path, or "
                              "the name of a file of share/phd_swarm/config/"),
        OpaqueFunction(function=_robot),
    ])
