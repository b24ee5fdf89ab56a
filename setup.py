"""Build step that ships the trees, scenes and studies inside the package.

The metadata lives in pyproject.toml. A built package (``pip install .``, a wheel) gets a copy of
``trees/``, ``sim/`` and ``studies/`` in ``tactile_bt/_shipped/``, where
:mod:`tactile_bt.shipped` finds them; an editable install reads them from the checkout.
"""

from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
SHIPPED = ("trees", "sim", "studies")


class BuildWithShippedFiles(build_py):
    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return
        for folder in SHIPPED:
            for src in sorted((HERE / folder).rglob("*")):
                if src.is_file() and "__pycache__" not in src.parts:
                    dst = Path(self.build_lib) / "tactile_bt" / "_shipped" / src.relative_to(HERE)
                    self.mkpath(str(dst.parent))
                    self.copy_file(str(src), str(dst))


setup(cmdclass={"build_py": BuildWithShippedFiles})
