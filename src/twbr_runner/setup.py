from setuptools import find_packages, setup

package_name = "twbr_runner"

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
    description="What runs and records a node graph: runner, rosbag2 (MCAP) recorder, metrics, figures, driver check.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "recorder = twbr_runner.recorder:main",
            "run_scenario = twbr_runner.runner:main",
            "check_driver = twbr_runner.check_driver:main",
            "recover_bag = twbr_runner.recover_bag:main",
        ],
    },
)
