"""``somite report``: a campaign directory's results beside the paper's (see :mod:`.build`)."""
