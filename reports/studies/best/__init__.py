"""The best-configuration search (``sweep --best``) and the one-frame check of the paper's
configuration against ``--preset best`` (``volcaustics frames``)."""
