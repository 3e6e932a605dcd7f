"""The recorder's command line: a bad batch period is refused before any bag is created."""

from __future__ import annotations

import pytest

from twbr_runner.recorder import parse_args


@pytest.mark.parametrize("period", ["0", "-0.01", "61", "nan"])
def test_a_drain_period_outside_its_range_is_refused_with_the_range(tmp_path, capsys, period):
    with pytest.raises(SystemExit) as e:
        parse_args(["-o", str(tmp_path / "bag"), "-a", "--drain-period", period])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "invalid --drain-period" in err and "must be in (0, 60] s" in err


def test_the_default_period_takes_messages_every_10_ms(tmp_path):
    args = parse_args(["-o", str(tmp_path / "bag"), "-a"])
    assert args.drain_period == 0.01
    assert not (tmp_path / "bag").exists()
