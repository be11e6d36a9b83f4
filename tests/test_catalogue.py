"""schemas.catalogue: one table every part reads, consistent with itself, the type registry,
the configurations whose keys it names, and the code that publishes and subscribes."""

from __future__ import annotations

import pytest
from pydantic import BaseModel

from clients.report.stats import SENSOR_TOPICS
from clients.stack.launcher import NAVIGATION_TOPICS, SIMULATOR_TOPICS
from guidance.config import GuidanceConfig
from navigation.config import LidarConfig, NavigationConfig
from navigation.node import IMU_INPUT, SENSOR_INPUTS
from navigation.processors import OUTPUT_TYPES, Processors
from schemas.catalogue import (
    PRODUCERS,
    ROLES,
    TOPICS,
    by_name,
    consumed_by,
    period_s,
    published_by,
    streams_of,
)
from schemas.registry import TypeRegistry
from simulator.config import SimConfig
from simulator.sensor import config_value
from simulator.sensors import SENSORS

CONFIGS: dict[str, BaseModel] = {
    "simulator": SimConfig(),
    "navigation": NavigationConfig(),
    "guidance": GuidanceConfig(),
}


def test_keys_and_names_are_unique_and_roles_and_producers_known():
    topics = list(TOPICS.values())
    assert len({t.name for t in topics}) == len(topics)
    assert all(key == t.key for key, t in TOPICS.items())
    assert {t.role for t in topics} <= set(ROLES)
    assert {t.producer for t in topics} <= set(PRODUCERS)
    assert all(t.name.startswith("/") and t.summary for t in topics)
    assert by_name("/lidar/points") is TOPICS["lidar"] and by_name("/nope") is None


def test_every_type_is_registered(registry: TypeRegistry):
    unknown = [t.type for t in TOPICS.values() if not registry.has_message(t.type)]
    assert not unknown


def test_each_topic_says_how_often_it_comes_one_way():
    for topic in TOPICS.values():
        ways = [
            bool(topic.rate_key),
            bool(topic.follows),
            topic.period_s is not None,
            topic.latched,
        ]
        expected = 0 if topic.role == "command" else 1
        assert sum(ways) == expected, topic.key
        if topic.follows:
            assert by_name(topic.follows) is not None, topic.key


@pytest.mark.parametrize("producer", ["simulator", "navigation", "guidance"])
def test_rate_and_switch_keys_exist_in_the_producers_configuration(producer):
    for topic in published_by(producer):
        if topic.rate_key:
            assert config_value(CONFIGS[producer], topic.rate_key) > 0, topic.key
        if topic.enabled_by:
            assert isinstance(config_value(CONFIGS[producer], topic.enabled_by), bool)
    with pytest.raises(AttributeError, match=r"lidar\.rate_hertz"):
        config_value(SimConfig(), "lidar.rate_hertz")


def test_fixed_periods_and_their_absence_are_named():
    assert period_s("trace") == 0.25
    with pytest.raises(KeyError, match="/lidar/points has no fixed period"):
        period_s("lidar")


def test_the_simulators_sensors_are_its_catalogue_streams():
    assert [f.topic.key for f in SENSORS] == [
        t.key for t in published_by("simulator", "sensor", "realtime")
    ]
    for factory in SENSORS:
        topic = factory.topic
        assert topic.role == ("sensor" if factory.schedule == "worker" else "realtime")
        physics = topic.rate_key == "vessel.physics_rate_hz"
        assert physics == (factory.schedule == "physics"), topic.key
    # and /sim/status, who commands the vessel (simulator.command)
    assert set(SIMULATOR_TOPICS) == {f.topic.name for f in SENSORS} | {TOPICS["sim_status"].name}


def test_navigation_reads_and_writes_what_the_catalogue_says():
    assert set(SENSOR_INPUTS.values()) | {IMU_INPUT} == {t.pair for t in consumed_by("navigation")}
    assert {t.name: t.type for t in published_by("navigation")} == OUTPUT_TYPES
    assert NAVIGATION_TOPICS == streams_of("navigation") == tuple(OUTPUT_TYPES)
    handlers = Processors(NavigationConfig(lidar=LidarConfig(worker="thread"))).handlers()
    assert handlers.keys() == SENSOR_INPUTS.keys()


def test_the_report_measures_the_thesis_sensors():
    assert SENSOR_TOPICS == (
        "/lidar/points",
        "/radar/image",
        "/camera/image/compressed",
        "/imu/data",
    )
