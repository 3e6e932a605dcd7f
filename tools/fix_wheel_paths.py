"""Rewrite the build paths baked into the ROS 2 PyPI wheels to this virtual environment's.

The wheels are built in a manylinux image under /opt/python/cp311-cp311; their CMake exports name that
image's Python and numpy include directories and their ament index names it as a parent prefix, so a
rosidl package would not configure against them unchanged. Idempotent: a second run changes nothing.
"""

from __future__ import annotations

import sys
import sysconfig
from pathlib import Path

import numpy

BAKED = "/opt/python/cp311-cp311"


def replacements(prefix: Path) -> list[tuple[str, str]]:
    """Most specific first, so the bare prefix is rewritten last."""
    py = f"python{sys.version_info.major}.{sys.version_info.minor}"
    return [
        (f"{BAKED}/lib/{py}/site-packages/numpy/_core/include", numpy.get_include()),
        (f"{BAKED}/include/{py}", sysconfig.get_paths()["include"]),
        (BAKED, str(prefix)),
    ]


def fix(prefix: Path) -> int:
    subs = replacements(prefix)
    changed = 0
    for path in (prefix / "share").rglob("*"):
        if not path.is_file() or path.suffix in {".pyc", ".so"}:
            continue
        try:
            text = path.read_text()
        except (UnicodeDecodeError, OSError):
            continue
        if BAKED not in text:
            continue
        for old, new in subs:
            text = text.replace(old, new)
        path.write_text(text)
        changed += 1
    return changed


if __name__ == "__main__":
    prefix = Path(sys.argv[1] if len(sys.argv) > 1 else sys.prefix).resolve()
    print(f"fix_wheel_paths: rewrote {fix(prefix)} file(s) under {prefix}/share")
