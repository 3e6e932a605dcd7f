from setuptools import find_packages, setup

package_name = "twbr_sim"

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
    description="Simulated two-wheeled balancing robot (nonlinear dynamics, DC motors) and its world.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "sim_node = twbr_sim.sim_node:main",
            "world_node = twbr_sim.world_node:main",
            "torque_driver = twbr_sim.torque_driver:main",
            "command_player = twbr_sim.command_player:main",
        ],
    },
)
