"""What a reader sees: the accuracy report (``report``, drawn by ``page``), the files of the
single-render commands (``exports``) and the figures' shared conventions (``figures``)."""
