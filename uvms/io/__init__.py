"""Files and the terminal: atomic writes and run folders replaced whole (:mod:`.outputs`), progress bars."""
