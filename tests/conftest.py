"""Shared fixtures: the shipped models, loaded once per test session."""

from __future__ import annotations

import functools

import numpy as np
import pytest

import uvms

SHIPPED = sorted(uvms.shipped_models())


@functools.lru_cache(maxsize=None)
def shipped(name: str) -> uvms.Robot:
    """A shipped model, loaded once (tests must not mutate it)."""
    return uvms.load(name)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261122)
