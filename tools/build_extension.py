"""Build the extension zip with Blender's own extension tool (shipped in the bpy wheel) and
validate it: ``python tools/build_extension.py [OUT_DIR]`` (``make package``). Prints the zip's
path and size."""
from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def blender_ext() -> Path:
    spec = importlib.util.find_spec("bpy")
    if spec is None or not spec.submodule_search_locations:
        raise SystemExit("bpy is not installed: run `make setup`")
    found = sorted(Path(list(spec.submodule_search_locations)[0]).glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        raise SystemExit("Blender's extension tool (bl_pkg/cli/blender_ext.py) is not in this bpy")
    return found[-1]


def build(out_dir: Path) -> Path:
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    tool = str(blender_ext())
    r = subprocess.run([sys.executable, tool, "build", "--source-dir", str(ROOT), "--output-dir", str(out_dir)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"build failed:\n{r.stdout}\n{r.stderr}")
    zips = sorted(out_dir.glob("lamella-*.zip"), key=lambda p: p.stat().st_mtime)
    if not zips:
        raise SystemExit(f"build wrote no zip:\n{r.stdout}")
    r = subprocess.run([sys.executable, tool, "validate", str(zips[-1])], capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"validation failed:\n{r.stdout}\n{r.stderr}")
    return zips[-1]


if __name__ == "__main__":
    z = build(Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "dist")
    print(f"{z} ({z.stat().st_size / 1e3:.0f} kB), validated")
