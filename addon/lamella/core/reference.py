"""``lamella.core.reference``, the stochastic ground truth of the Python API contract
(docs/design.md, "Contract: the Python API"), is ``lamella_dev.reference``: the yardstick is
development code and does not ship in the extension (the manifest leaves this module out too).
This name keeps the contract's import path working wherever the development package is
installed (a checkout, a wheel); it is the one place ``lamella`` names ``lamella_dev``."""
import sys

import lamella_dev.reference as _reference

sys.modules[__name__] = _reference
