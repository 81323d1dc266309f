"""A compiled kernel named by its module and imported at its first use (uvms.numerics._kernels.Kernel)."""

from __future__ import annotations

import subprocess
import sys


def test_a_named_kernel_loads_numba_at_its_first_use_and_is_then_the_function_itself():
    code = """
import sys
from uvms.numerics._kernels import Kernel
kernel = Kernel("runge_kutta", "weighted_sum_into")
assert kernel.function is None and "numba" not in sys.modules
loaded = kernel.load()
from uvms.numerics._kernels.runge_kutta import weighted_sum_into
assert loaded is weighted_sum_into and kernel.function is loaded and kernel.load() is loaded and "numba" in sys.modules
"""
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)
