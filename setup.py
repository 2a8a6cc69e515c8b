"""ament_python package gear_rotor_sim (the repository root is the package)."""

from glob import glob

from setuptools import find_packages, setup

package_name = "gear_rotor_sim"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(
        include=["gear_rotor_sim", "gear_rotor_sim.*", "lumped_gearbox", "lumped_gearbox.*"]
    ),
    package_data={"gear_rotor_sim": ["py.typed"]},
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
        ("share/" + package_name + "/launch", glob("launch/*.py")),
    ],
    install_requires=["setuptools", "numpy", "scipy", "numba", "pyyaml", "mcap"],
    zip_safe=False,
    maintainer="gear_rotor_sim maintainers",
    maintainer_email="maintainers@gear-rotor-sim.org",
    description="Digital twin of a gear-rotor-bearing system with steady-state temperature effects.",
    license="Apache-2.0",
    python_requires=">=3.10",
    entry_points={
        "console_scripts": [
            "gear-rotor-sim = gear_rotor_sim.cli:main",
            "simulator = gear_rotor_sim.ros.simulator_node:main",
            "monitor = gear_rotor_sim.ros.monitor_node:main",
        ],
    },
)
