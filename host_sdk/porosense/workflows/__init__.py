"""Workflows that run the whole product on a board: the demo (record the paper's protocol,
identify, quantize, flash, verify, stream, close the loop) with its report and its control
segment.

    demo             ``run_demo``: the main job, from nothing to an actuator that knows its strain
    demo_report      the demo's figures and summary page
    control_segment  the demo's closing act: PI gains tuned on its recordings, a few targets run
"""

from porosense.workflows.demo import DemoResult, run_demo

__all__ = ["DemoResult", "run_demo"]
