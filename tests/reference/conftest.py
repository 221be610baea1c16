"""Reference tests use llvm_ad_rgb directly (no variant probing) unless told otherwise."""

import os

os.environ.setdefault("VOLCAUSTICS_MI_VARIANT", "llvm_ad_rgb")
