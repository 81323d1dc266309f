"""Hydrodynamic parameters written as the YAML file that
:func:`uvms.dynamics.hydro.uuv.load_hydrodynamics_yaml` reads: the inverse of that reader, in the file's
uuv_simulator conventions (SNAME axes for the added mass and damping, Fossen's negative derivatives, the centre of
buoyancy in the link frame).

Every number is written with Python's shortest round-trip representation, so reading the file back gives the
same floats; a link's ``neutrally_buoyant`` or shape model (cylinder, box...) is written as its resolved
``fossen`` numbers and volume.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from .parameters import HydroParameters, LinkHydrodynamics, flip_frd_flu


def _number(value: float) -> str:
    return repr(float(value) + 0.0)  # + 0.0: no -0.0


def _row(values: Iterable[float]) -> str:
    return "[" + ", ".join(_number(value) for value in values) + "]"


def comment_line(text: str) -> str:
    """``text`` on one line: every character that is not printable (line breaks of any kind, control characters)
    replaced by its Python escape, so that a comment cannot end early and start a YAML line."""
    return "".join(character if character.isprintable() else repr(character)[1:-1] for character in text)


def link_yaml_lines(name: str, link: LinkHydrodynamics) -> list[str]:
    """The lines of one link's entry under ``links:`` (indented by two spaces)."""
    added = flip_frd_flu(link.added_mass)  # uvms FLU -> the file's SNAME axes
    lines = [f"  {name}:", f"    volume: {_number(link.volume)}   # [m^3]",
             f"    center_of_buoyancy: {_row(link.center_of_buoyancy)}   # [m], link frame (FLU)",
             "    hydrodynamic_model:", "      type: fossen",
             "      added_mass:   # [kg, kg m, kg m^2], SNAME axes [u v w p q r]"]
    lines += [f"        - {_row(row)}" for row in added]
    lines += [f"      linear_damping: {_row(-link.linear_damping)}   # X_u, Y_v, ... <= 0",
              f"      quadratic_damping: {_row(-link.quadratic_damping)}   # X_u|u|, ... <= 0"]
    if np.any(link.linear_damping_forward_speed != 0):
        lines.append("      linear_damping_forward_speed: "
                     f"{_row(-link.linear_damping_forward_speed)}   # X_uu, ... <= 0")
    return lines


def hydrodynamics_yaml_text(hydro: HydroParameters, comments: Iterable[str] = ()) -> str:
    """The YAML text of ``hydro`` (fluid, current and every link), ``comments`` as ``#`` lines at the top, one line
    each: a character that is not printable (a line break in a file name) is written as its escape (``\\n``)."""
    lines = [f"# {comment_line(line)}" for line in comments]
    lines += [f"fluid_density: {_number(hydro.fluid_density)}   # [kg/m^3]",
              f"gravity: {_number(hydro.gravity)}   # [m/s^2]",
              f"current: {_row(np.asarray(hydro.current))}   # [m/s], world ENU", "links:"]
    for name, link in hydro.links.items():
        lines += link_yaml_lines(name, link)
    return "\n".join(lines) + "\n"
