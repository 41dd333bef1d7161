"""The world simulator alone, node ``/world``, as ``scripts/run_world.sh`` runs it.

    ros2 launch phd_swarm world.launch.py config:=dames_static.yaml

For robots started by hand (``robot.launch.py``) or on other machines. The config (a path,
or the name of a file of ``share/phd_swarm/config/``) is checked first. DDS stays on
loopback and ``ROS_DOMAIN_ID`` is 42 unless the caller exported others (docs/deployment.md
for several machines).
"""

from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.launch_description import LaunchDescription
from launch.substitutions import LaunchConfiguration

from phd_swarm.tools.launch_actions import single_node_actions
from phd_swarm.tools.launch_plan import find_config, world_process


def _world(context):
    config = str(find_config(LaunchConfiguration("config").perform(context)))
    return single_node_actions(world_process(config), config, context)


def generate_launch_description() -> LaunchDescription:
    """The ``config`` argument and the world node."""
    return LaunchDescription([
        DeclareLaunchArgument("config", description="the run's config file: a path, or the "
                              "name of a file of share/phd_swarm/config/"),
        OpaqueFunction(function=_world),
    ])
