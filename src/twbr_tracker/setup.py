from setuptools import find_packages, setup

package_name = "twbr_tracker"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
    ],
    install_requires=["setuptools"],
    zip_safe=False,
    maintainer="twbr maintainers",
    maintainer_email="maintainers@twbr.dev",
    description="Obstacles from a 2D LiDAR: segmentation, disc fitting, association, Kalman tracks.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "tracker_node = twbr_tracker.tracker_node:main",
        ],
    },
)
