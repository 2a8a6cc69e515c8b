"""Rewrite the manylinux include paths in the venv's ROS CMake exports to this interpreter's.

The ros-jazzy-* wheels export CMake targets naming /opt/python/cp311-cp311/... include directories,
which do not exist here, and CMake refuses them. Only files inside the venv are touched.
"""

from __future__ import annotations

import glob
import os
import sys
import sysconfig

import numpy

BAD_PY = "/opt/python/cp311-cp311/include/python3.11"
BAD_NP = "/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"


def main() -> int:
    share = os.path.join(sys.prefix, "share")
    good_py = sysconfig.get_paths()["include"]
    good_np = numpy.get_include()
    changed = 0
    for path in glob.glob(os.path.join(share, "**", "cmake", "*.cmake"), recursive=True):
        with open(path, encoding="utf-8", errors="surrogateescape") as f:
            text = f.read()
        if BAD_PY not in text and BAD_NP not in text:
            continue
        text = text.replace(BAD_NP, good_np).replace(BAD_PY, good_py)
        with open(path, "w", encoding="utf-8", errors="surrogateescape") as f:
            f.write(text)
        changed += 1
    print(f"[setup] fixed include paths in {changed} CMake files")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
