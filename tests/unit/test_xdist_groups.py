"""`make test` runs the suite on two workers with ``--dist loadgroup``: the modules whose fixtures
run Blender sessions or benches for minutes (``xdist_group``) must run on one worker, or each
worker pays for them. pytest 9.2 stopped reading the group suffix pytest-xdist 3.8 writes into
test ids, which silently cost minutes; this checks that the pinned pair keeps a group together."""
import subprocess
import sys

GROUPED = """
import os
import pytest

pytestmark = pytest.mark.xdist_group("together")


@pytest.mark.parametrize("k", range(6))
def test_worker(k):
    with open(os.path.join(os.path.dirname(__file__), "workers.txt"), "a") as f:
        f.write(os.environ["PYTEST_XDIST_WORKER"] + "\\n")
"""


def test_an_xdist_group_runs_on_one_worker(tmp_path):
    (tmp_path / "test_grouped.py").write_text(GROUPED)
    (tmp_path / "test_other.py").write_text("def test_a():\n    pass\n\n\ndef test_b():\n    pass\n")
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadgroup",
                        "-p", "no:cacheprovider", str(tmp_path)], capture_output=True, text=True, cwd=tmp_path,
                       timeout=300)
    assert r.returncode == 0, r.stdout[-2000:]
    workers = (tmp_path / "workers.txt").read_text().split()
    assert len(workers) == 6 and len(set(workers)) == 1, workers
