from glob import glob

from setuptools import find_packages, setup

package_name = "vibrissa_ros"

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
    extras_require={"test": ["pytest>=7", "mpmath>=1.3", "catkin_pkg>=1.0"]},
    zip_safe=True,
    maintainer="vibrissa_ros maintainers",
    maintainer_email="maintainers@vibrissa-ros.dev",
    description="Virtual artificial whisker for ROS 2: exact quasistatic elastica against convex obstacles.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "vibrissa = vibrissa_ros.cli:main",
        ],
    },
)
