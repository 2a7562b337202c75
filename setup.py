"""Everything is in pyproject.toml but this: ``zenroid-interfaces.pth`` installed beside the packages, so that
``from std_msgs.msg import String`` works in a fresh interpreter (``_zenroid_interfaces.py``).

setuptools has no declarative way to ship a ``.pth`` file. A wheel takes it from ``build_lib``; an editable
install (PEP 660) writes its wheel from the folder ``install_lib`` names, where it is copied instead."""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

PTH = Path(__file__).resolve().parent / "zenroid-interfaces.pth"


class BuildPyWithPth(build_py):
    def run(self) -> None:
        super().run()
        if self.editable_mode:
            target = Path(self.get_finalized_command("install").install_lib)
        else:
            target = Path(self.build_lib)
        target.mkdir(parents=True, exist_ok=True)
        self.copy_file(str(PTH), str(target / PTH.name))

    def get_outputs(self, *args, **kwargs) -> list[str]:
        return [*super().get_outputs(*args, **kwargs), str(Path(self.build_lib) / PTH.name)]


setup(cmdclass={"build_py": BuildPyWithPth})
