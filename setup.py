"""ament_python package definition of phd_swarm (versions agree with package.xml).

The console scripts are installed by colcon into ``lib/phd_swarm/`` (setup.cfg), where
``ros2 run phd_swarm <name>`` finds them: one per node (world, robot, team, monitor,
recorder; ``phd_swarm.tools.launch_plan.NODE_EXECUTABLES``) and the main tools
(``TOOL_EXECUTABLES``). The launch files go to ``share/phd_swarm/launch/``.
"""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "phd_swarm"

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        (f"share/{PACKAGE}/config/rviz", glob("config/rviz/*.rviz")),
        (f"share/{PACKAGE}/config/foxglove", glob("config/foxglove/*.json")),
        (f"share/{PACKAGE}/config/dds", glob("config/dds/*.xml")),
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="phd_swarm developers",
    maintainer_email="dev@phd-swarm.local",
    description="Distributed multi-robot PHD filter search and tracking on ROS 2",
    license="Apache-2.0",
    entry_points={"console_scripts": [
        # nodes: ros2 run phd_swarm robot --ros-args --params-file CONFIG -r __ns:=/robot_3
        #        -p robot_id:=3
        "world = phd_swarm.nodes.world:main",
        "robot = phd_swarm.nodes.robot:main",
        "team = phd_swarm.nodes.team:main",
        "monitor = phd_swarm.nodes.monitor:main",
        "recorder = phd_swarm.nodes.recorder:main",
        "viewer = phd_swarm.nodes.viewer:main",
        # tools: ros2 run phd_swarm run_swarm CONFIG --robots 4 ...
        "run_swarm = phd_swarm.tools.run_swarm:main",
        "check_config = phd_swarm.tools.check_config:main",
        "evaluate = phd_swarm.tools.evaluate:main",
        "replay = phd_swarm.tools.replay:main",
        "sweep = phd_swarm.tools.sweep:main",
        "log_check = phd_swarm.tools.log_check:main",
        "view_server = phd_swarm.tools.view_server:main",
    ]},
)
