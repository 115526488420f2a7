"""ament_python package definition of modal_twin."""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = "modal_twin"
NODES = [
    "excitation",
    "rig",
    "acquisition",
    "identification",
    "updating",
    "twin",
    "diagnosis",
]

setup(
    name=PACKAGE,
    version="0.1.0",
    packages=find_packages(include=[PACKAGE, f"{PACKAGE}.*"]),
    package_data={f"{PACKAGE}.io": ["fastdds_profiles.xml", "fastdds_profiles_network.xml"]},
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config/structures", glob("config/structures/*.yaml")),
        (f"share/{PACKAGE}/config/rigs", glob("config/rigs/*.yaml")),
        (f"share/{PACKAGE}/config/scenarios", glob("config/scenarios/*.yaml")),
        (f"share/{PACKAGE}/config/matrix_models", glob("config/matrix_models/*.yaml")),
    ],
    install_requires=["setuptools", "numpy", "scipy", "PyYAML", "rosbags", "mcap"],
    zip_safe=True,
    maintainer="modal_twin developers",
    maintainer_email="modal-twin@example.com",
    description="Structural vibration testing and digital twins on ROS 2 Jazzy.",
    license="Apache-2.0",
    tests_require=["pytest"],
    entry_points={
        "console_scripts": [
            "modal-twin = modal_twin.cli:main",
            *[f"{n}_node = modal_twin.{n}.node:main" for n in NODES],
            "recorder_node = modal_twin.io.recorder:main",
            "replay_node = modal_twin.io.replay:main",
            "display_node = modal_twin.viz.node:main",
        ],
    },
)
