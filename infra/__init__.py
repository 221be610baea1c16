"""What every package needs and no scene knows: the one error type of bad input
(``errors``), atomic writes and the caches' storage (``storage``), EXR and PNG files
(``imageio``), interrupt handling (``interrupts``), memory checks (``memory``). The
bottom layer: it imports no other folder of the project."""
