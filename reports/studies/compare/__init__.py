"""``volcaustics compare``: any renderer's images of a scene against the ground truth
(docs/howto/other-renderer.md: ``inputs`` reads and checks the EXRs,
``run`` measures them as the approximation is measured, ``write`` writes the folder,
``read`` reads it back for the report and the gate."""
