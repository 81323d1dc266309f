"""The benchmarks' own reading of what they measure: callgrind's file as ``step_instructions.py`` counts it."""

from __future__ import annotations

import sys
from collections import Counter
from pathlib import Path

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"

#: A callgrind file as valgrind 3.19 writes it (compressed names, relative positions), with code inlined from a
#: header (fi/fe), a call's inclusive cost line (after calls=), a cost line without its trailing event, Pinocchio's
#: algorithm and a boost::python caller in Pinocchio's module, and JIT code.
CALLGRIND = """# callgrind format
version: 1
creator: callgrind-3.19.0
positions: line
events: Ir I1mr
summary: 1187

ob=(1) /usr/lib/libpython3.11.so.1.0
fl=(1) Python/ceval.c
fn=(1) _PyEval_EvalFrameDefault
10 100 2
fi=(2) Include/object.h
+1 50 1
fe=(1)
* 7
cob=(2) /site-packages/pinocchio/pinocchio_pywrap_default.cpython-311-x86_64-linux-gnu.so
cfi=(3) pinocchio/algorithm/aba.hxx
cfn=(2) pinocchio::impl::abaLocalConvention<double>(pinocchio::ModelTpl<double> const&)
calls=1 0
-1 1000 9

ob=(2)
fl=(3)
fn=(2)
0 900 8
fn=(3) boost::python::objects::caller_py_function_impl<pinocchio::python::aba_proxy>::operator()
0 100 1

ob=(3) ???
fl=(4) ???
fn=(4) 0x000000000abc
0 30

totals: 1187
"""


def test_callgrind_costs_are_counted_where_they_ran_inlined_code_included_calls_once(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    sys.modules.pop("step_instructions", None)
    import step_instructions as counting

    path = tmp_path / "run.callgrind"
    path.write_text(CALLGRIND)
    events, costs = counting.object_costs(path)
    assert events == ["Ir", "I1mr"]
    module = "/site-packages/pinocchio/pinocchio_pywrap_default.cpython-311-x86_64-linux-gnu.so"
    assert costs == {
        "/usr/lib/libpython3.11.so.1.0": {"Ir": 157, "I1mr": 3},  # the inlined header's 50 in, the call's 1000 out
        counting.ALGORITHMS + module: {"Ir": 900, "I1mr": 8},  # aba's own work, compiled into the module
        module: {"Ir": 100, "I1mr": 1},  # the boost::python caller: the bindings
        "???": {"Ir": 30, "I1mr": 0},  # JIT code, its missing event 0
    }
    assert sum(cost["Ir"] for cost in costs.values()) == 1187  # callgrind's own total

    by_object = Counter({counting.file_name(name): cost["Ir"] for name, cost in costs.items()})
    assert counting.by_component(by_object) == Counter({
        "the interpreter": 157, "Pinocchio's algorithms": 900, "Pinocchio's bindings": 100,
        "numba's kernels (JIT code)": 30})
