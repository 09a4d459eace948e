"""The progress bar behind `progress=True`: one line on stderr, only when stderr is a terminal."""

import sys
import time


class bar:
    """Called with (stage, done, total) ten times a second during a long call, and (None, 0, 0) at its end."""

    def __init__(self, stream=None):
        self.stream = stream or sys.stderr
        self.enabled = hasattr(self.stream, "isatty") and self.stream.isatty()
        self.start = time.monotonic()
        self.drawn = False

    def __call__(self, stage, done, total):
        if not self.enabled:
            return
        if stage is None:
            if self.drawn:
                self.stream.write("\r\033[K")
                self.stream.flush()
            return
        fraction = done / total if total else 0.0
        width = 30
        filled = int(round(fraction * width))
        self.stream.write("\r\033[K%s [%s%s] %3d%% %.1f s" % (stage, "#" * filled, "." * (width - filled),
                                                            int(fraction * 100), time.monotonic() - self.start))
        self.stream.flush()
        self.drawn = True
