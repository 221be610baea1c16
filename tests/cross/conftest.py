"""Approximation-vs-reference tests: the reference runs on llvm_ad_rgb directly (no
variant probing, as in tests/reference) unless told otherwise."""

import os

os.environ.setdefault("VOLCAUSTICS_MI_VARIANT", "llvm_ad_rgb")
