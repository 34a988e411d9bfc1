"""Playback of a clip's frames: play, pause, frame step, speed, loop (no GUI: the session drives it)."""

from __future__ import annotations

from dataclasses import dataclass

#: Playback speeds the GUI offers (a factor of the clip's own rate).
SPEEDS = (0.1, 2.0)


@dataclass
class Player:
    """A playhead over ``n_frames`` frames at ``fps``.

    ``frame`` is fractional while playing; :attr:`index` is the frame shown. With ``loop`` the
    playhead wraps at the end, otherwise it stops on the last frame.
    """

    n_frames: int
    fps: float
    frame: float = 0.0
    playing: bool = True
    speed: float = 1.0
    loop: bool = True

    @property
    def index(self) -> int:
        return int(min(max(self.frame, 0.0), self.n_frames - 1))

    def tick(self, seconds: float) -> int:
        """Advance by ``seconds`` of wall time (when playing); returns the frame to show."""
        if self.playing and self.n_frames > 1:
            f = self.frame + seconds * self.fps * self.speed
            if f > self.n_frames - 1:
                if self.loop:
                    f %= self.n_frames
                else:
                    f, self.playing = float(self.n_frames - 1), False
            self.frame = f
        return self.index

    def step(self, frames: int) -> int:
        """Pause and move by ``frames`` (wrapping when looping)."""
        self.playing = False
        f = self.index + frames
        self.frame = float(f % self.n_frames if self.loop else min(max(f, 0), self.n_frames - 1))
        return self.index

    def seek(self, frame: int) -> int:
        self.frame = float(min(max(int(frame), 0), self.n_frames - 1))
        return self.index
