"""What every figure shares: matplotlib without a display and the error maps' fixed
colour scales."""
