"""ament_python package definition of phd_swarm (versions agree with package.xml)."""

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
    ],
    install_requires=["setuptools"],
    zip_safe=True,
    maintainer="phd_swarm developers",
    maintainer_email="dev@phd-swarm.local",
    description="Distributed multi-robot PHD filter search and tracking on ROS 2",
    license="Apache-2.0",
    entry_points={"console_scripts": []},
)
