from glob import glob

from setuptools import find_packages, setup

package_name = "vibrissa_ros"

ROS = [
    "ros-jazzy-rclpy",
    "ros-jazzy-rmw-fastrtps-cpp",
    "ros-jazzy-common-interfaces",
    "ros-jazzy-ament-index-python",
    "mcap>=1.2",  # recording (rosbag2 layout), with zstd chunks
    "zstandard",
]
# building and isolating: colcon (the CI build check) and unique ROS_DOMAIN_IDs for tests
TOOLS = ["colcon-common-extensions", "colcon-ros", "ros-jazzy-ament-package", "ros-jazzy-domain-coordinator"]
# two independent readers of our logs, for the round-trip tests
READERS = ["mcap-ros2-support", "rosbags"]
PLOTS = ["matplotlib>=3.7"]
# studies at scale (vibrissa batch): Dask distributed, Parquet through pyarrow (pandas for DataFrames),
# a progress bar, YAML study files; lower bounds: the first releases that build against numpy 2
BATCH = ["dask[distributed]>=2024.8.0", "pyarrow>=16.0", "pandas>=2.2.2", "tqdm>=4.60", "pyyaml>=5.4"]
# the dataset's other readers, for the read-back tests
DATASET_READERS = ["dask[dataframe]>=2024.8.0", "polars>=1.0"]
# the core's own tests: they also run on numpy 1.x (.ci/run), without ROS
CORE_TEST = ["pytest>=7", "mpmath>=1.3", "hypothesis>=6.100"]

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test", "test.*"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
    ],
    python_requires=">=3.10",
    install_requires=["setuptools", "numpy>=1.24", "scipy>=1.10"],
    extras_require={
        # ROS 2 Jazzy from PyPI wheels (no sourcing needed), for the node and its tools
        "ros": ROS + PLOTS,
        "plots": PLOTS,
        "batch": BATCH,
        "core-test": CORE_TEST,
        "test": ROS + TOOLS + READERS + PLOTS + BATCH + DATASET_READERS + CORE_TEST + ["catkin_pkg>=1.0"],
    },
    zip_safe=True,
    maintainer="vibrissa_ros maintainers",
    maintainer_email="maintainers@vibrissa-ros.dev",
    description="Virtual artificial whisker for ROS 2: exact quasistatic elastica against convex obstacles.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "vibrissa = vibrissa_ros.cli:main",
            "whisker_node = vibrissa_ros.whisker_node:main",
            "contour_node = vibrissa_ros.contour_node:main",
        ],
    },
)
