"""The hand-written part of a generated benchmark document: everything from the analysis marker on is kept
when a script regenerates the tables above it."""

PLACEHOLDER = "(No analysis yet: text written below this marker is kept when the tables are regenerated.)"


def kept_analysis(path, marker):
    """The lines to end a regenerated document with: the old document's text from `marker` on, or the marker
    and a placeholder when there is none yet."""
    try:
        with open(path) as f:
            old = f.read()
    except OSError:
        old = ""
    if marker in old:
        return [old[old.index(marker):].rstrip()]
    return [marker, "", PLACEHOLDER]
