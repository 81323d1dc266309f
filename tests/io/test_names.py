"""The plain-name rule (uvms.io.names): one rule for every name from a file that becomes a path."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import uvms
from uvms.io.names import default_output_folder, is_plain_name, plain_file_name


@pytest.mark.parametrize("name", ["hoang2011_w1", "bluerov2_alpha5", "my-run_2.v1", "a" * 128, "0rov"])
def test_plain_names_pass(name):
    assert is_plain_name(name)


@pytest.mark.parametrize("name", ["x/../../../important_run", "..", "a..b", ".hidden", "-flag", "", "a b", "a/b",
                                  "a\\b", "a" * 129, "é", None, 3])
def test_other_names_do_not(name):
    assert not is_plain_name(name)


@given(st.text(max_size=300))
def test_the_cleaned_name_is_always_plain(text):
    assert is_plain_name(plain_file_name(text, "fallback"))


def test_a_model_name_names_the_default_folder_only_when_plain():
    assert default_output_folder("identify", "bluerov2_alpha5") == Path("out") / "identify_bluerov2_alpha5"
    for name in ("x/../../../important_run", "../escape", "rov 2", None):
        with pytest.raises(uvms.UVMSError, match="cannot name the output folder out/identify_<name>.*pass --out DIR"):
            default_output_folder("identify", name)


def test_the_scenario_layer_uses_the_same_rule():
    from uvms.scenario.spec import scenario

    assert scenario.is_plain_name is is_plain_name and scenario.NAME_RULE is uvms.io.names.NAME_RULE
