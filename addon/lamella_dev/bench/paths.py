"""Where the benches read and write: the checkout's stored references and its bench/ folder."""
from pathlib import Path


def _repository() -> Path:
    """The checkout this package runs from (where the stored references and bench/ live), or the
    working folder for an installed copy, so that a benchmark never writes into site-packages."""
    here = Path(__file__).resolve().parents[3]
    return here if (here / "pyproject.toml").is_file() and (here / "tests").is_dir() else Path.cwd()


REPO = _repository()
REFERENCE_DIR = REPO / "tests" / "references" / "brdf"  # single-scattering rough interfaces
REFERENCE_DIR_MULTIPLE = REPO / "tests" / "references" / "brdf_multiple"  # multiple-scattering interfaces
BENCH_DIR = REPO / "bench"
