from setuptools import find_packages, setup

package_name = "twbr_batch"

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
    description="twbr without ROS, at scale: batch engine, Monte Carlo studies, headless closed loop and gain tuning.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "montecarlo = twbr_batch.montecarlo:main",
            "suite = twbr_batch.suite:main",
            "warm = twbr_batch.warm:main",
        ],
    },
)
