from glob import glob

from setuptools import find_packages, setup

package_name = "vibrissa_ros"

# Lower bounds are the first release with every API we call (checked against that release):
# mcap 1.5: Writer.flush (1.4 has none: a recorder thread would die of it); it brings zstandard.
# tqdm 4.60: tqdm(total, unit, file, disable, dynamic_ncols, desc), update, the context manager,
# tqdm.write(file=). The ros-jazzy-* wheels are one ROS distribution, versioned together.
ROS = [
    "ros-jazzy-rclpy",
    "ros-jazzy-rmw-fastrtps-cpp",
    "ros-jazzy-common-interfaces",
    "ros-jazzy-std-srvs",  # std_srvs/Trigger of ~/reset
    "ros-jazzy-ament-index-python",
    "mcap>=1.5",  # recording (rosbag2 layout), with zstd chunks
    "tqdm>=4.60",  # progress bars of vibrissa sweep and replay
]
# building and isolating: colcon (the CI build check) and unique ROS_DOMAIN_IDs for tests
TOOLS = ["colcon-common-extensions", "colcon-ros", "ros-jazzy-ament-package",
         "ros-jazzy-domain-coordinator"]
# two independent readers of our logs, for the round-trip tests
# (mcap-ros2-support 0.5: mcap_ros2.decoder.DecoderFactory; rosbags 0.9.20: typesys.Stores.EMPTY
# and get_typestore)
READERS = ["mcap-ros2-support>=0.5", "rosbags>=0.9.20"]
# matplotlib 3.7: subplots(layout=, height_ratios=); pillow 9.1: Image.Quantize, Image.Dither
PLOTS = ["matplotlib>=3.7", "pillow>=9.1"]
# style checks as ament_flake8 / ament_pep257 configure them (test/test_style.py); pyyaml 5.1:
# yaml.safe_load of the launch test's parameter files
LINT = ["flake8>=6.0", "pydocstyle>=6.1", "pyyaml>=5.1"]
# studies at scale (vibrissa batch): Dask distributed, Parquet through pyarrow (pandas for
# DataFrames), a progress bar, YAML study files; lower bounds: the first releases that build
# against numpy 2
BATCH = ["dask[distributed]>=2024.8.0", "pyarrow>=16.0", "pandas>=2.2.2", "tqdm>=4.60",
         "pyyaml>=5.4"]
# the dataset's other readers, for the read-back tests
DATASET_READERS = ["dask[dataframe]>=2024.8.0", "polars>=1.0"]
# the documentation site (doc/, built by test/test_docs.py); lower bounds from the projects'
# changelogs: myst-parser 2.0: fenced directives, (label)= targets, myst_heading_anchors and the
# dollarmath, deflist, colon_fence extensions, on Sphinx 6 or 7 (hence sphinx 6); numpydoc 1.6: a
# validator that handles properties and decorated functions (numpydoc_validation_checks and
# numpydoc_validation_exclude); sphinx-rtd-theme 2.0: the first release for Sphinx 7; the API
# pages import the log and dataset modules, hence mcap and pyarrow (as ROS and BATCH bound them)
DOC = ["sphinx>=6.1", "myst-parser>=2.0", "numpydoc>=1.6", "sphinx-rtd-theme>=2.0",
       "mcap>=1.5", "pyarrow>=16.0"] + PLOTS
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
        ("share/" + package_name + "/launch", glob("launch/*.launch.xml")),
    ],
    python_requires=">=3.10",
    # pyyaml 5.1: safe_dump(sort_keys=False) of scene files; numba 0.57: the first release that
    # supports numpy 1.24 (our lowest); the 3D whisker's kernels use only njit(cache=True,
    # nogil=True), loops, math and np.dot, which are older
    install_requires=["setuptools", "numpy>=1.24", "scipy>=1.10", "pyyaml>=5.1", "numba>=0.57"],
    extras_require={
        # ROS 2 Jazzy from PyPI wheels (no sourcing needed), for the node and its tools
        "ros": ROS + PLOTS,
        "plots": PLOTS,
        "batch": BATCH,
        "core-test": CORE_TEST,
        "doc": DOC,
        "test": ROS + TOOLS + READERS + PLOTS + BATCH + DATASET_READERS + CORE_TEST + LINT + DOC
        + ["catkin_pkg>=1.0"],
    },
    zip_safe=True,
    maintainer="vibrissa_ros maintainers",
    maintainer_email="maintainers@vibrissa-ros.dev",
    description="Virtual artificial whisker for ROS 2: exact quasistatic elastica against convex "
                "obstacles.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "vibrissa = vibrissa_ros.cli:main",
            "whisker_node = vibrissa_ros.ros.whisker_node:main",
            "contour_node = vibrissa_ros.ros.contour_node:main",
            "array_node = vibrissa_ros.ros.array_node:main",
        ],
    },
)
