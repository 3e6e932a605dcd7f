"""Which executor the nodes spin, and a refused choice."""

from __future__ import annotations

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor

from twbr_common import executor
from twbr_common.params import ConfigError


@pytest.fixture
def context():
    ctx = rclpy.Context()
    rclpy.init(context=ctx)
    yield ctx
    rclpy.try_shutdown(context=ctx)


def test_events_executor_by_default(monkeypatch, context):
    from rclpy.experimental import EventsExecutor  # the rclpy this project installs has it

    monkeypatch.delenv(executor.ENV, raising=False)
    ex = executor.new_executor(context)
    assert type(ex).__name__ == type(EventsExecutor(context=context)).__name__
    assert not isinstance(ex, SingleThreadedExecutor)


def test_single_threaded_on_request(monkeypatch, context):
    monkeypatch.setenv(executor.ENV, "single")
    assert isinstance(executor.new_executor(context), SingleThreadedExecutor)


def test_an_unknown_choice_is_refused_with_its_name(monkeypatch):
    monkeypatch.setenv(executor.ENV, "multi")
    with pytest.raises(ConfigError, match="TWBR_EXECUTOR = 'multi': must be one of events, single"):
        executor.executor_kind()
