"""The samples of a control run, shared by the Device-level and simboard control tests."""

from __future__ import annotations

from porosense.protocol import StatusFlag


def controlled_samples(
    dev, n: int, *, limit: int = 5000, timeout_s: float = 20.0, ping_every: int = 20, ping: bool = True
) -> list:
    """n samples from the first controlled one on (the back-end may have queued samples made
    before the start), pinging every ``ping_every`` samples when ``ping`` so a live host keeps
    the watchdog fed; fewer when ``limit`` samples pass first."""
    out = []
    for k, s in enumerate(dev.samples(limit, timeout_s=timeout_s)):
        if out or s.status & StatusFlag.CONTROL_ACTIVE:
            out.append(s)
        if ping and k % ping_every == ping_every - 1:
            dev.ping()
        if len(out) >= n:
            break
    return out
