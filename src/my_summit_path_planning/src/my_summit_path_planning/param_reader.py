"""One parameter reader for move_base and its plugins: typed fields, ranges, old names, notes.

Reference: roscpp's NodeHandle::param (a name that is not set takes the default; a name
nobody asks for is never read), nav_core's parameter_magic.h (loadParameterWithDeprecation:
an old name is read when the current one is not set, with a warning; warnRenamedParameter:
an old name is only warned about, nothing is read) and dynamic_reconfigure, which moves a
value outside its .cfg's range to the nearest bound.

Each parameter is declared once, as a Field: its ROS name, its Kind, the real node's
default, its range and what a value outside it does (ParamError, or clamped with a note),
its old names. ``Schema(fields).read(params, where)`` returns a Reading: every field's
value by name and one list of notes, each a Note (a str, with .kind and .param), for the
node to log once:

  UNREAD   a name no field reads: left unread, as roscpp leaves it (with the nearest name)
  RENAMED  an old name, read or not as the real node does, with nav_core's warning
  CLAMPED  a value moved to its range's bound
  INVALID  a bad value replaced by the default, where the real node does so
  WARNING  the real node's warning about a value it keeps (made by the caller)

A value of the wrong kind, or outside a range that rejects, raises ParamError (or the
caller's error class) naming the parameter: ``where: 'name' must be ..., got ...``
followed by the parameter's path ``where/name``.
"""
import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

from summit_nav_common.params import unread_note

UNREAD, RENAMED, CLAMPED, INVALID, WARNING = "unread", "renamed", "clamped", "invalid", "warning"

# nav_core's warnings (parameter_magic.h), word for word.
RENAMED_NOT_READ = "Parameter {old} is deprecated (and will not load properly). Use {new} instead."
RENAMED_READ = "Parameter {old} is deprecated. Please use the name {new} instead."


class ParamError(ValueError):
    """A parameter of the wrong type or out of range (or a malformed namespace)."""


class Note(str):
    """One thing to log about the parameters: its text, what kind of note (UNREAD, RENAMED,
    CLAMPED, INVALID, WARNING) and the parameter it is about."""

    def __new__(cls, kind, param, text):
        note = super().__new__(cls, text)
        note.kind, note.param = kind, param
        return note


# -- kinds -------------------------------------------------------------------------------
@dataclass(frozen=True)
class Kind:
    """What a parameter's value may be. check(value) returns the value as the field keeps it,
    or raises ValueError whose text (if any) replaces name in "must be <name>"."""

    name: str
    check: Callable


def _is_number(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _check(ok, text=""):
    if not ok:
        raise ValueError(text)


def _bool(v):
    _check(isinstance(v, bool))
    return v


def _int(v):
    _check(isinstance(v, int) and not isinstance(v, bool))
    return v


def _float(v):
    _check(_is_number(v))
    _check(math.isfinite(v), "finite")
    return float(v)


def _str(v):
    _check(isinstance(v, str))
    return v


def _list(v):
    _check(isinstance(v, list))
    return v


def _str_list(v):
    _check(isinstance(v, list) and all(isinstance(x, str) for x in v))
    return v


def _float_list(v):
    """A list of finite numbers, or its string form "[-0.3, -0.1, 0.1]" (dynamic_reconfigure's)."""
    items = v
    if isinstance(v, str):
        try:
            items = [float(t) for t in v.replace("[", " ").replace("]", " ").replace(",", " ").split()]
        except ValueError:
            raise ValueError("") from None
    _check(isinstance(items, (list, tuple)) and all(_is_number(x) and math.isfinite(x) for x in items))
    return tuple(float(x) for x in items)


BOOL = Kind("bool", _bool)
INT = Kind("int", _int)
FLOAT = Kind("float", _float)
STR = Kind("str", _str)
LIST = Kind("a list", _list)
STR_LIST = Kind("a list of strings", _str_list)
FLOAT_LIST = Kind("a list of floats", _float_list)
ANY = Kind("anything", lambda v: v)

KINDS = {bool: BOOL, int: INT, float: FLOAT, str: STR, list: LIST, tuple: FLOAT_LIST,
         "bool": BOOL, "int": INT, "float": FLOAT, "str": STR, "list": LIST, "tuple": FLOAT_LIST}


# -- fields ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Field:
    """One parameter as the real node declares it.

    name: the ROS name; kind: a Kind; default: the real node's (factory: a callable making
    it, for a mutable one); optional: None is accepted as a value. lo, hi: the range
    (lo_open: lo itself excluded); clamp: a value outside it is moved to the bound with a
    CLAMPED note (as dynamic_reconfigure does) instead of raising. choices: the values
    allowed; fallback: a value outside the range or choices takes the default with an
    INVALID note (the real node's fallback) instead of raising. old: names read when name
    is not set (loadParameterWithDeprecation); renamed: names only warned about
    (warnRenamedParameter); either may hold (old name, the real node's own warning)
    pairs. what: the words for the kind in errors, where the real node's differ from the
    kind's name; note: the real node's text for a CLAMPED or INVALID note, formatted with
    where, name, value, bound, default and choices.
    """

    name: str
    kind: Kind = ANY
    default: object = None
    factory: Callable = None
    optional: bool = False
    lo: float = None
    hi: float = None
    lo_open: bool = False
    clamp: bool = False
    choices: tuple = None
    fallback: bool = False
    old: tuple = ()
    renamed: tuple = ()
    what: str = None
    note: str = None

    def default_value(self):
        return self.factory() if self.factory is not None else self.default

    def range_text(self):
        """The range in words ("in [1, 255]", "> 0", ">= 0.0", "<= 5"), '' when none."""
        if self.lo is not None and self.hi is not None:
            return f"in {'(' if self.lo_open else '['}{self.lo}, {self.hi}]"
        if self.lo is not None:
            return f"{'>' if self.lo_open else '>='} {self.lo}"
        if self.hi is not None:
            return f"<= {self.hi}"
        return ""

    def in_range(self, v):
        if self.lo is not None and (v <= self.lo if self.lo_open else v < self.lo):
            return False
        return self.hi is None or v <= self.hi


def _old_names(items):
    """[(old name, own text or None), ...] of a Field's old or renamed."""
    return [(i, None) if isinstance(i, str) else (i[0], i[1]) for i in items]


@dataclass
class Reading:
    """What Schema.read returns: values {name: value} for every field (the default where
    not set), notes [Note, ...] in the order found, given: the fields set in the
    namespace (under their name or a read old name)."""

    values: dict
    notes: list
    given: frozenset

    def __getitem__(self, name):
        return self.values[name]


class Schema:
    """The fields of one namespace. accepted: further names the node reads (elsewhere, or
    without effect here): never noted as unread. The old names of the fields are known too."""

    def __init__(self, fields, accepted=()):
        self.fields = {f.name: f for f in fields}
        self.accepted = tuple(accepted)
        self.known = sorted(set(self.fields) | set(self.accepted)
                            | {o for f in fields for o, _ in _old_names(f.old) + _old_names(f.renamed)})

    @classmethod
    def of(cls, config_class, internal=(), accepted=(), **overrides):
        """The schema of a dataclass of parameters: one Field per dataclass field (kind from
        its annotation, default from its default; a None default makes it optional), but
        those named in internal; overrides: {field name: {Field attribute: value}}."""
        fields = []
        for f in dataclasses.fields(config_class):
            if f.name in internal:
                continue
            kw = dict(name=f.name, kind=KINDS.get(f.type, ANY))
            if f.default_factory is not dataclasses.MISSING:
                kw["factory"] = f.default_factory
            else:
                kw["default"] = f.default
                kw["optional"] = f.default is None
            kw.update(overrides.pop(f.name, {}))
            fields.append(Field(**kw))
        if overrides:
            raise ValueError(f"{config_class.__name__} has no field(s) {sorted(overrides)}")
        return cls(fields, accepted)

    def defaults(self):
        return {name: f.default_value() for name, f in self.fields.items()}

    def read(self, params, where, note_where=None, error=ParamError):
        """A Reading of params (a dict; None: all defaults). where names the namespace in
        errors; note_where in UNREAD notes (default where; '' for none). error: the
        exception class raised for a bad value (ParamError)."""
        if params is None:
            params = {}
        if not isinstance(params, dict):
            raise error(f"{where}: expected a mapping of parameters, got {params!r}")
        note_where = where if note_where is None else note_where
        values, notes, given = {}, [], set()
        for name, f in self.fields.items():
            key = name if name in params else None
            for old, text in _old_names(f.renamed):
                if old in params:
                    notes.append(Note(RENAMED, old, text or RENAMED_NOT_READ.format(old=old, new=name)))
            for old, text in _old_names(f.old):
                if old not in params:
                    continue
                if text is not None:
                    notes.append(Note(RENAMED, old, text))
                if key is None:
                    key = old
                    if text is None:
                        notes.append(Note(RENAMED, old, RENAMED_READ.format(old=old, new=name)))
            if key is None:
                values[name] = f.default_value()
                continue
            given.add(name)
            values[name] = self._value(f, key, params[key], where, notes, error)
        notes += [Note(UNREAD, k, unread_note(note_where, k, self.known))
                  for k in sorted(map(str, params)) if k not in self.known]
        return Reading(values, notes, frozenset(given))

    @staticmethod
    def _value(f, key, value, where, notes, error):
        path = f"({where}/{key})"
        if value is None and f.optional:
            return None
        try:
            value = f.kind.check(value)
        except ValueError as e:
            raise error(f"{where}: '{key}' must be {str(e) or f.what or f.kind.name}, got {value!r} {path}") \
                from None
        bad_choice = f.choices is not None and value not in f.choices
        if not bad_choice and (f.lo is None and f.hi is None or f.in_range(value)):
            return value
        text = dict(where=where, name=key, value=value, default=f.default_value(), choices=f.choices)
        if f.fallback:
            notes.append(Note(INVALID, key, (f.note or "{where}: '{name}' {value!r} is not valid; the default "
                                             "{default!r} is used").format(**text)))
            return f.default_value()
        if f.clamp and not bad_choice:
            low = f.lo is not None and value < f.lo
            bound = f.lo if low else f.hi
            text["bound"] = bound
            notes.append(Note(CLAMPED, key, (f.note or "{where}: '{name}' {value} " + (
                "raised to {bound}, its least value" if low else "lowered to {bound}, its greatest value")
                ).format(**text)))
            return type(value)(bound)
        if bad_choice:
            raise error(f"{where}: '{key}' must be one of {', '.join(map(str, f.choices))}, got {value!r} {path}")
        raise error(f"{where}: '{key}' must be {f.range_text()}, got {value!r} {path}")
