"""What uvms reads from uuv_simulator's thruster plugin (uvms.dynamics.thrusters.sources): the steady-state thrust
range of the plugin's chain (clamp, gain, efficiencies, conversion, thrustMin/thrustMax) and the time constant.

The expected numbers are the plugin's chain evaluated by hand at the ends of the input range.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import pytest

from uvms.dynamics.plugins.readers import read_thruster_plugins
from uvms.dynamics.thrusters.sources import plugin_thrust_range, plugin_time_constant
from uvms.errors import ModelCheckError

BASIC = "<conversion><type>Basic</type><rotorConstant>0.00031</rotorConstant></conversion>"
FIRST = "<dynamics><type>FirstOrder</type><timeConstant>0.05</timeConstant></dynamics>"
#: A Blue Robotics T200-like table: PWM-like input -> thrust [N].
TABLE = ("<conversion><type>LinearInterp</type><inputValues>-200 -100 0 100 200</inputValues>"
         "<outputValues>-40.2 -18 0 22 51.5</outputValues></conversion>")


def plugin(body: str) -> ET.Element:
    return ET.fromstring(f'<plugin name="t" filename="libuuv_thruster_ros_plugin.so">{body}</plugin>')


@pytest.mark.parametrize("body, expected", [
    (FIRST + BASIC, (-math.inf, math.inf)),  # the RexROV's form: the plugin gives no limit
    (FIRST + BASIC + "<thrustMin>-40</thrustMin><thrustMax>50</thrustMax>", (-40.0, 50.0)),
    (FIRST + BASIC + "<thrustMax>50</thrustMax>", (-math.inf, 50.0)),
    # clamp [-1000, 1500] rad/s, gain 0.9, propeller efficiency 0.8: rotor in [-720, 1080];
    # thrust 0.00031 x|x| times thrust efficiency 0.5: [-80.352, 180.792]
    (FIRST + BASIC + "<clampMin>-1000</clampMin><clampMax>1500</clampMax><gain>0.9</gain>"
     "<propeller_efficiency>0.8</propeller_efficiency><thrust_efficiency>0.5</thrust_efficiency>",
     (-0.5 * 0.00031 * 720.0 ** 2, 0.5 * 0.00031 * 1080.0 ** 2)),
    # the same clamp with thrustMax 100 N on top
    (FIRST + BASIC + "<clampMin>-1000</clampMin><clampMax>1500</clampMax><gain>0.9</gain>"
     "<propeller_efficiency>0.8</propeller_efficiency><thrustMax>100</thrustMax>",
     (-0.00031 * 720.0 ** 2, 100.0)),
    (FIRST + TABLE, (-40.2, 51.5)),  # a table bounds the thrust by itself
    (FIRST + TABLE + "<clampMin>-150</clampMin><clampMax>50</clampMax>", (-(18 + 40.2) / 2, 11.0)),
    ("<dynamics><type>Yoerger</type><alpha>1</alpha><beta>2</beta></dynamics>" + TABLE, (-40.2, 51.5)),
    ("<dynamics><type>Yoerger</type><alpha>1</alpha><beta>2</beta></dynamics>" + BASIC
     + "<clampMax>100</clampMax>", (-math.inf, math.inf)),  # nonlinear rotor: the clamp does not bound it here
    # Bessa dead zone: rotor clamped to [-10, 20]: 0.5 (-100 - (-4)) and 0.25 (400 - 9)
    (FIRST + "<conversion><type>Bessa</type><rotorConstantL>0.5</rotorConstantL><rotorConstantR>0.25"
     "</rotorConstantR><deltaL>-4</deltaL><deltaR>9</deltaR></conversion><clampMin>-10</clampMin><clampMax>20"
     "</clampMax>", (0.5 * (-100 + 4), 0.25 * (400 - 9))),
])
def test_the_thrust_range_is_the_plugins_chain_at_the_ends_of_its_input(body, expected):
    low, high = plugin_thrust_range(plugin(body), "t")
    assert low == pytest.approx(expected[0], rel=1e-12) and high == pytest.approx(expected[1], rel=1e-12)


def test_the_time_constant_is_a_first_order_ones_only():
    assert plugin_time_constant(plugin(FIRST), "t") == 0.05
    assert plugin_time_constant(plugin("<dynamics><type>ZeroOrder</type></dynamics>"), "t") is None  # no lag
    assert plugin_time_constant(plugin("<dynamics><type>Bessa</type></dynamics>"), "t") is None
    assert plugin_time_constant(plugin(""), "t") is None
    with pytest.raises(ModelCheckError, match="t: the FirstOrder timeConstant must be > 0 s, got '0'"):
        plugin_time_constant(plugin(FIRST.replace("0.05", "0")), "t")


def robot(plugins: str, joint: str = '<axis xyz="0 0 2"/>') -> ET.Element:
    return ET.fromstring(f'<robot name="r"><link name="b"/><link name="p"/><joint name="j" type="fixed">'
                         f'<parent link="b"/><child link="p"/>{joint}</joint><gazebo>{plugins}</gazebo></robot>')


def test_plugins_are_read_with_what_they_give_and_the_joint_axis():
    thrusters = read_thruster_plugins(robot(
        '<plugin name="a" filename="libuuv_thruster_ros_plugin.so"><linkName>p</linkName><jointName>j</jointName>'
        f'{FIRST}{BASIC}<thrustMax>50</thrustMax></plugin>'
        '<plugin name="other" filename="libsomething_else.so"><linkName>p</linkName></plugin>'
        f'<plugin name="b" filename="libuuv_thruster_ros_plugin.so"><linkName>p</linkName>{TABLE}</plugin>'), "m")
    assert [(t.name, t.link) for t in thrusters] == [("a", "p"), ("b", "p")]
    assert thrusters[0].direction.tolist() == [0.0, 0.0, 1.0] and thrusters[1].direction is None
    assert thrusters[0].given == {"max_forward": 50.0, "time_constant": 0.05}
    assert thrusters[1].given == {"max_forward": 51.5, "max_reverse": 40.2}


@pytest.mark.parametrize("body, message", [
    (FIRST, "m: uuv_simulator thruster plugin 'a': <linkName> is missing"),
    ("<linkName>p</linkName><thrustMax>-5</thrustMax>", "its largest thrust is -5 N; a thruster must push forward"),
    ("<linkName>p</linkName><jointName>k</jointName>", "unknown joint 'k'; valid joints: j"),
    ("<linkName>b</linkName><jointName>j</jointName>", "jointName 'j' does not carry linkName 'b'"),
    ("<linkName>p</linkName>" + TABLE.replace("51.5</", "51.5 60</"),
     "a LinearInterp conversion needs as many inputValues as outputValues .* got 5 and 6"),
])
def test_bad_plugins_are_refused_naming_them(body, message):
    with pytest.raises(ModelCheckError, match=message):
        read_thruster_plugins(robot(f'<plugin name="a" filename="libuuv_thruster_ros_plugin.so">{body}</plugin>'),
                              "m")


def test_a_propeller_joint_without_an_axis_is_refused():
    with pytest.raises(ModelCheckError, match="the axis of joint 'j' must be 3 numbers, not all zero, got "
                                              r"\[0.0, 0.0, 0.0\]"):
        read_thruster_plugins(robot('<plugin name="a" filename="libuuv_thruster_ros_plugin.so"><linkName>p</linkName>'
                                    '<jointName>j</jointName></plugin>', '<axis xyz="0 0 0"/>'), "m")
