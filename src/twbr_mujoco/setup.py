from setuptools import find_packages, setup

package_name = "twbr_mujoco"

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
    description="The TWBR simulated by MuJoCo (multibody, wheel-ground contact), as a driver on the twbr contract.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "mujoco_driver = twbr_mujoco.mujoco_driver:main",
        ],
    },
)
