"""Where MuJoCo keeps what the compiled collision functions read: byte offsets of fields in the C
structs ``mjModel``, ``mjData`` and ``mjPreContact`` of the installed MuJoCo, and the address of its
public collision table ``mjCOLLISIONFUNC`` (``mujoco.h``: ``MJAPI extern mjfCollision
mjCOLLISIONFUNC[mjNGEOMTYPES][mjNGEOMTYPES]``).

The offsets come from the struct declarations that the mujoco wheel ships for its own bindings
(``mujoco.introspect.structs``, generated from the installed headers), laid out with ``ctypes``
(which follows the platform's C ABI), and are then checked against a live model and data: every
pointer field read at its offset must equal the address of the array that the Python bindings hand
out for it, and every size field the binding's value. A MuJoCo whose layout does not check out gives
no layout (None), and the world keeps MuJoCo's own collision functions.

No numba here: plain ``ctypes``.
"""

from __future__ import annotations

import ctypes
import logging
import os
from dataclasses import dataclass

log = logging.getLogger(__name__)

__all__ = ["Layout", "StepLayout", "layout_for", "step_layout", "step_functions", "table_slot_addresses"]

#: mjModel pointer fields the collision functions read, with the numpy dtype the bindings give them
MODEL_ARRAYS = {"geom_dataid": "int32", "geom_size": "float64", "geom_rbound": "float64",
                "hfield_size": "float64", "hfield_nrow": "int32", "hfield_ncol": "int32",
                "hfield_adr": "int32", "hfield_data": "float32"}
#: mjData pointer fields they read
DATA_ARRAYS = {"geom_xpos": "float64", "geom_xmat": "float64"}
#: mjPreContact fields they write, in the order of its declaration (mjdata.h), each mjtNum
PRECONTACT_FIELDS = (("dist", 1), ("pos", 3), ("normal", 3), ("tangent", 3))


@dataclass(frozen=True)
class Layout:
    """Byte offsets of the fields that the compiled collision functions use (the installed MuJoCo)."""

    model: dict
    """mjModel field name -> byte offset of its pointer."""
    data: dict
    """mjData field name -> byte offset of its pointer."""
    precontact_size: int
    """sizeof(mjPreContact), bytes: ten mjtNum (dist, pos, normal, tangent) in MuJoCo 3.3 to 4.0."""


_VALUE_TYPES = {
    "int": ctypes.c_int, "mjtNum": ctypes.c_double, "double": ctypes.c_double, "float": ctypes.c_float,
    "size_t": ctypes.c_size_t, "uintptr_t": ctypes.c_size_t, "char": ctypes.c_char,
    "mjtByte": ctypes.c_ubyte, "mjtBool": ctypes.c_bool, "mjtSize": ctypes.c_int64,
    "int64_t": ctypes.c_int64, "uint64_t": ctypes.c_uint64, "unsigned int": ctypes.c_uint,
}


def _ctypes_structs():
    """ctypes mirrors of MuJoCo's structs from ``mujoco.introspect``: {name: Structure class}."""
    from mujoco.introspect import ast_nodes as ast
    from mujoco.introspect import structs

    made: dict = {}

    def ctype(t):
        if isinstance(t, ast.PointerType):
            return ctypes.c_void_p
        if isinstance(t, ast.ArrayType):
            c = ctype(t.inner_type)
            for extent in reversed(t.extents):
                c = c * extent
            return c
        if isinstance(t, (ast.AnonymousStructDecl, ast.AnonymousUnionDecl)):
            base = ctypes.Union if isinstance(t, ast.AnonymousUnionDecl) else ctypes.Structure
            return type("anonymous", (base,), {"_fields_": [(f.name, ctype(f.type)) for f in t.fields]})
        name = t.name
        if name in _VALUE_TYPES:
            return _VALUE_TYPES[name]
        if name in structs.STRUCTS:
            return struct(name)
        if name.startswith("mjt"):  # an enum (mjtGeom, mjtObj, ...): a C int
            return ctypes.c_int
        raise KeyError(f"MuJoCo struct field type {name!r} unknown to offroadbench's layout")

    def struct(name: str):
        if name not in made:
            cls = type(name, (ctypes.Structure,), {})
            made[name] = cls
            cls._fields_ = [(f.name, ctype(f.type)) for f in structs.STRUCTS[name].fields]
        return made[name]

    return {name: struct(name) for name in ("mjModel", "mjData", "mjPreContact", "mjContact")}


def _compute_layout() -> Layout:
    c = _ctypes_structs()
    model = {name: getattr(c["mjModel"], name).offset for name in MODEL_ARRAYS}
    data = {name: getattr(c["mjData"], name).offset for name in DATA_ARRAYS}
    pre = c["mjPreContact"]
    names = [f[0] for f in pre._fields_]
    if names != [f[0] for f in PRECONTACT_FIELDS] or ctypes.sizeof(pre) != 80:
        raise KeyError(f"mjPreContact is {names} ({ctypes.sizeof(pre)} bytes), expected dist, pos, normal, tangent")
    return Layout(model=model, data=data, precontact_size=ctypes.sizeof(pre))


def _checks_out(layout: Layout, model, data) -> bool:
    """Every pointer at its offset in ``model`` / ``data`` is the address of the binding's array."""
    for table, obj, dtypes in ((layout.model, model, MODEL_ARRAYS), (layout.data, data, DATA_ARRAYS)):
        base = obj._address
        for name, off in table.items():
            arr = getattr(obj, name)
            if str(arr.dtype) != dtypes[name] or arr.size == 0:
                return False
            if ctypes.c_void_p.from_address(base + off).value != arr.ctypes.data:
                return False
    return True


_LAYOUT: list = []  # [Layout | None], computed once per process


def layout_for(model, data) -> Layout | None:
    """The installed MuJoCo's layout, checked against this ``model`` (a ``mujoco.MjModel`` with a
    height field and a geom) and its ``data``; None where the introspection is missing or the
    layout does not check out (logged once)."""
    if not _LAYOUT:
        try:
            _LAYOUT.append(_compute_layout())
        except (ImportError, KeyError, AttributeError, TypeError) as exc:
            log.warning("MuJoCo's struct layout is unavailable (%s): MuJoCo's own height-field collision", exc)
            _LAYOUT.append(None)
    layout = _LAYOUT[0]
    if layout is not None and not _checks_out(layout, model, data):
        log.warning("MuJoCo's struct layout does not check out against a model: MuJoCo's own height-field collision")
        return None
    return layout


def _libmujoco():
    """The MuJoCo library the bindings loaded (dlopen of the same file returns the same handle)."""
    import mujoco

    folder = list(mujoco.__path__)[0]  # the package folder, where the wheel puts libmujoco
    path = os.path.join(folder, f"libmujoco.so.{mujoco.__version__}")
    if not os.path.exists(path):  # other platforms' names
        names = [n for n in os.listdir(folder) if n.startswith(("libmujoco", "mujoco.dll"))]
        if not names:
            raise OSError(f"no MuJoCo library in {folder}")
        path = os.path.join(folder, sorted(names)[0])
    return ctypes.CDLL(path)


def table_slot_addresses(pairs) -> tuple[int, ...]:
    """Addresses of the entries ``mjCOLLISIONFUNC[type1][type2]`` for each (type1, type2) in ``pairs``
    (``mujoco.mjtGeom`` values, type1 <= type2 as MuJoCo looks them up)."""
    import mujoco

    n = int(mujoco.mjtGeom.mjNGEOMTYPES)
    table = ctypes.addressof(ctypes.c_void_p.in_dll(_libmujoco(), "mjCOLLISIONFUNC"))
    size = ctypes.sizeof(ctypes.c_void_p)
    return tuple(table + size * (int(a) * n + int(b)) for a, b in pairs)


@dataclass(frozen=True)
class StepLayout:
    """Where a compiled trial step finds the contacts of the MuJoCo step it just took (byte offsets)."""

    ncon: int
    """mjData's ``ncon`` (int)."""
    nefc: int
    """mjData's ``nefc`` (int)."""
    contact: int
    """mjData's ``contact`` pointer."""
    efc_force: int
    """mjData's ``efc_force`` pointer."""
    contact_size: int
    """sizeof(mjContact), bytes (a multiple of 8)."""
    dist: int
    """Offsets in mjContact of ``dist``, ``pos``, ``frame`` (mjtNum), ``geom``, ``efc_address`` (int)."""
    pos: int
    frame: int
    geom: int
    efc_address: int

    def as_tuple(self) -> tuple[int, ...]:
        """The offsets in the order the kernels index them (offroadbench.sim.engines.mujoco._tyres_c.S_*)."""
        return (self.ncon, self.nefc, self.contact, self.efc_force, self.contact_size, self.dist, self.pos,
                self.frame, self.geom, self.efc_address)


_PROBE_XML = """<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
<body pos="0 0 0.09"><freejoint/><geom type="box" size="0.1 0.1 0.1"/></body></worldbody></mujoco>"""


def _probe_checks_out(lay: StepLayout) -> bool:
    """``lay`` read on a box resting on a plane (contacts and constraint rows in the data) gives what
    the bindings give: ncon, nefc, the contact and efc_force arrays' addresses and every field's."""
    import mujoco

    m = mujoco.MjModel.from_xml_string(_PROBE_XML)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    if d.ncon < 2 or d.nefc < 2:
        return False
    base = d._address
    ints = (ctypes.c_int.from_address(base + lay.ncon).value, ctypes.c_int.from_address(base + lay.nefc).value)
    if ints != (d.ncon, d.nefc):
        return False
    if ctypes.c_void_p.from_address(base + lay.efc_force).value != d.efc_force.ctypes.data:
        return False
    contact = ctypes.c_void_p.from_address(base + lay.contact).value
    c = d.contact
    fields = ((c.dist, lay.dist, "float64"), (c.pos, lay.pos, "float64"), (c.frame, lay.frame, "float64"),
              (c.geom, lay.geom, "int32"), (c.efc_address, lay.efc_address, "int32"))
    return all(arr.ctypes.data == contact + off and arr.strides[0] == lay.contact_size and str(arr.dtype) == dtype
               for arr, off, dtype in fields)


_STEP: list = []  # [StepLayout | None], once per process


def step_layout() -> StepLayout | None:
    """The installed MuJoCo's :class:`StepLayout`, checked on a probe model; None where it is not
    available or does not check out (logged once)."""
    if not _STEP:
        lay = None
        try:
            c = _ctypes_structs()
            data, con = c["mjData"], c["mjContact"]
            lay = StepLayout(ncon=data.ncon.offset, nefc=data.nefc.offset, contact=data.contact.offset,
                             efc_force=data.efc_force.offset, contact_size=ctypes.sizeof(con), dist=con.dist.offset,
                             pos=con.pos.offset, frame=con.frame.offset, geom=con.geom.offset,
                             efc_address=con.efc_address.offset)
            if lay.contact_size % 8 or not _probe_checks_out(lay):
                log.warning("MuJoCo's mjData / mjContact layout does not check out: the trial step stays in Python")
                lay = None
        except (ImportError, KeyError, AttributeError, TypeError) as exc:
            log.warning("MuJoCo's struct layout is unavailable (%s): the trial step stays in Python", exc)
        _STEP.append(lay)
    return _STEP[0]


def step_functions() -> tuple[int, int, int]:
    """Addresses of MuJoCo's ``mj_step``, ``mj_step1`` and ``mj_step2``."""
    lib = _libmujoco()
    return tuple(ctypes.cast(getattr(lib, name), ctypes.c_void_p).value for name in ("mj_step", "mj_step1", "mj_step2"))
