import pytest

from robot_controller.scoring.verdict import judge

BAND = 0.02


def _run(**figures):
    """A clean one-joint run's figures, with ``figures`` over them."""
    values = {
        "joint_names": ["joint1"],
        "joint_units": ["rad"],
        "scored_samples": 1000,
        "tracking_max_per_joint": [0.004],
        "start_tracking_max_per_joint": [0.005],
        "brake_engagements": 0,
        "braked_s": 0.0,
    }
    return values | figures


def test_a_run_within_its_band_is_ok():
    verdict = judge(_run(), band_rad=BAND)
    assert verdict.ok and verdict.line == "ok"
    assert verdict.as_metrics() == {"verdict": "ok", "verdict_reasons": []}


def test_tracking_beyond_the_band_fails_naming_the_band_and_the_joint():
    values = _run(
        joint_names=["shoulder", "wrist"],
        joint_units=["rad", "rad"],
        tracking_max_per_joint=[0.03, 0.407],
        start_tracking_max_per_joint=[0.001, 0.001],
    )
    verdict = judge(values, band_rad=BAND)
    assert not verdict.ok
    said = "FAILED: tracking 407 mrad on wrist off its reference, beyond its 20 mrad tracking band"
    assert verdict.line.startswith(said)
    assert "1 other joint" in verdict.line
    assert verdict.as_metrics()["verdict"] == "failed"


def test_the_start_is_judged_by_the_same_band():
    verdict = judge(_run(start_tracking_max_per_joint=[0.172]), band_rad=BAND)
    assert verdict.reasons == ("in its first 2 s 172 mrad off its reference, beyond its 20 mrad tracking band",)


def test_a_push_someone_asked_for_is_left_out():
    values = _run(tracking_max_per_joint=[0.3], unpushed_max_per_joint=[0.004])
    assert judge(values, band_rad=BAND).ok
    failed = judge(values | {"unpushed_max_per_joint": [0.05]}, band_rad=BAND)
    assert "pushes left out" in failed.line


@pytest.mark.parametrize("unscored", [{"scored_samples": 0}, {"tracking_max_per_joint": [float("nan")]}])
def test_a_run_with_nothing_scored_is_never_ok(unscored):
    values = _run(**unscored, start_tracking_max_per_joint=[float("nan")])
    assert "nothing to judge" in judge(values, band_rad=BAND).line


def test_a_run_shorter_than_its_start_is_judged_by_its_start():
    assert judge(_run(scored_samples=0, tracking_max_per_joint=[float("nan")]), band_rad=BAND).ok
    failed = judge(_run(scored_samples=0, start_tracking_max_per_joint=[0.3]), band_rad=BAND)
    assert failed.line.startswith("FAILED: in its first 2 s 300 mrad")


def test_brakes_for_a_fault_fail_and_an_estop_does_not():
    braked = _run(brake_engagements=2, braked_s=0.4, brake_engagements_estop=1, braked_s_estop=0.3)
    assert judge(braked, band_rad=BAND).reasons == ("the brakes held the arm once for a fault (0.10 s in all)",)
    estopped = _run(brake_engagements=1, braked_s=4.0, brake_engagements_estop=1, braked_s_estop=4.0, stopped_ticks=400)
    assert judge(estopped, band_rad=BAND).ok


def test_stops_nobody_asked_for_fail():
    verdict = judge(_run(watchdog_ticks=3, law_fault_ticks=5), band_rad=BAND)
    assert verdict.reasons == ("stops nobody asked for (watchdog 3, law_fault 5 ticks)",)


def test_a_run_that_failed_is_said_by_its_failure_alone():
    """The law's stop and brakes are what its failure did: one line, the launcher's."""
    values = _run(law_fault_ticks=51, brake_engagements=1, braked_s=2.0)
    verdict = judge(values, band_rad=BAND, failure="the control law failed: boom")
    assert verdict.line == "FAILED: the control law failed: boom"


def test_a_run_its_recording_covers_only_in_part_is_never_ok():
    """A bag torn 2.24 s into a 10 s run (its folder removed under the recorder) once scored ``ok`` on what was left."""
    verdict = judge(_run(duration_s=10.0, recorded_duration_s=2.24), band_rad=BAND)
    assert verdict.reasons == ("its recording covers 2.24 s of its 10 s: the rest is not judged",)
    assert judge(_run(duration_s=10.0, recorded_duration_s=9.99), band_rad=BAND).ok  # the last period: whole
    assert judge(_run(duration_s=5.0, recorded_duration_s=5.09), band_rad=BAND).ok  # the wall clock's tail
