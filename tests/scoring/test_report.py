"""The motor's once-a-second receipts are paired with the controller's ticks offline."""

import numpy as np

from robot_controller.scoring.report import motor_latency_s


def test_each_receipt_pairs_with_the_latest_tick_that_issued_its_command():
    state = {
        "command": np.array([[1.0], [2.0], [1.0], [3.0]]),
        "measurement_stamp_s": np.array([0.00, 0.01, 0.02, 0.03]),
    }
    receipts = np.array(
        [
            [0.004, 1.0],  # tick 0
            [0.013, 2.0],  # tick 1
            [0.0235, 1.0],  # tick 2, not tick 0: the latest reading before the receipt
            [0.036, 3.0],  # tick 3
            [0.040, 9.0],
        ]
    )  # no tick issued 9.0: not a latency
    assert np.allclose(motor_latency_s(state, receipts), [0.004, 0.003, 0.0035, 0.006])
