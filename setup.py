"""ament_python package swazure_ros (also installable with plain pip)."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "swazure_ros"

setup(
    name=PACKAGE,
    version="0.2.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    # The Fast DDS profile every process of a swarm loads (ros/plumbing/participants.py).
    package_data={f"{PACKAGE}.ros.plumbing": ["participants.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml") + glob("config/*.xml")),
        (f"share/{PACKAGE}/config/cameras", glob("config/cameras/*.yaml")),
        (f"share/{PACKAGE}/config/swarms", glob("config/swarms/*.yaml")),
        (f"share/{PACKAGE}/config/track", glob("config/track/*")),
        # Viewers' files: `rviz2 -d .../config/rviz/swarm.rviz`, Foxglove's "Import layout".
        (f"share/{PACKAGE}/config/rviz", glob("config/rviz/*.rviz")),
        (f"share/{PACKAGE}/config/foxglove", glob("config/foxglove/*.json")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
        # `ros2 run swazure_ros <program>` runs lib/swazure_ros/<program>.
        (f"lib/{PACKAGE}", glob("scripts/nodes/*")),
    ],
    install_requires=["setuptools"],
    python_requires=">=3.10",
    zip_safe=True,
    maintainer="Swazure developers",
    maintainer_email="swazure@flyinglightspecks.org",
    description="Swazure: relative pose of blind neighbours in a swarm of Flying Light Specks",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "swazure = swazure_ros.cli.main:main",
        ],
    },
)
