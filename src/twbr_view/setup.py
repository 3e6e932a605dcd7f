from setuptools import find_packages, setup

package_name = "twbr_view"

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
    description="A live view of the twbr graph, and of any recorded bag, in the Rerun web viewer.",
    license="Apache-2.0",
    entry_points={
        "console_scripts": [
            "viewer = twbr_view.viewer_node:main",
            "view_bag = twbr_view.view_bag:main",
        ],
    },
)
