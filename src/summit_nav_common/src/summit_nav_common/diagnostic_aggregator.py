"""diagnostic_aggregator's Aggregator, GenericAnalyzer and AnalyzerGroup, without ROS.

Reference: the ROS wiki's diagnostic_aggregator page and its GenericAnalyzer and
AnalyzerGroup documentation (ros/diagnostics, noetic). The aggregator takes every
DiagnosticStatus published on /diagnostics, gives each to the analyzers that match its
name, and publishes, once per pub_rate, the analyzed statuses renamed under their
analyzer's path plus one status per path with the worst level of what is under it:

- Names: an item named "amcl: Standard deviation" analyzed by an analyzer at path
  "/Navigation Stack/Localization" is reported as "/Navigation Stack/Localization/amcl:
  Standard deviation" ('/' in an item's name becomes ' '). remove_prefix (and
  find_and_remove_prefix, which is also a startswith) strips a leading prefix, then a
  ':' and spaces after it, from the last path element.
- GenericAnalyzer matches by regex (whole name), expected, name (equal), startswith,
  contains. Its header status is "OK", "Warning", "Error" or "Stale" by the worst item; an
  item not updated for `timeout` [s] (default 5; <= 0: never) is Stale; some stale items
  make the header Error, all stale make it Stale; `expected` items never seen are
  reported Stale with message "Missing"; `num_items` (> 0) other than the number of
  items is an Error; `discard_stale` drops stale items.
- AnalyzerGroup: `path` and nested `analyzers`; its header comes after its children's
  statuses, with their headers' messages as values, Error when some but not all are
  Stale.
- Items no analyzer matched go to "<base_path>/Other" (stale after 5 s and then dropped;
  with other_as_errors its header is an Error).
- The top-level state is the worst level of everything published, Stale only when all
  is stale (else Error).

Times are ROS time [s] passed in (the node's clock, simulated under use_sim_time). A bad
analyzer configuration does not stop the others: AnalyzerGroup records the error (a
ConfigError naming the parameter, e.g. "~analyzers/navigation: unknown type 'foo/Bar'")
and reports it as a Stale status under its path, as the real group reports a failed
analyzer; the caller logs `errors`.
"""
import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Tuple

OK, WARN, ERROR, STALE = 0, 1, 2, 3
LEVEL_MESSAGES = {OK: "OK", WARN: "Warning", ERROR: "Error", STALE: "Stale"}
DEFAULT_TIMEOUT = 5.0        # [s] GenericAnalyzer's timeout
OTHER_TIMEOUT = 5.0          # [s] the Other analyzer's (it discards stale items)
GENERIC_TYPES = ("diagnostic_aggregator/GenericAnalyzer", "GenericAnalyzer")
GROUP_TYPES = ("diagnostic_aggregator/AnalyzerGroup", "AnalyzerGroup")
MATCH_KEYS = ("startswith", "contains", "name", "expected", "regex")
STRING_LIST_KEYS = MATCH_KEYS + ("remove_prefix", "find_and_remove_prefix")
GENERIC_KEYS = ("type", "path", "timeout", "num_items", "discard_stale") + STRING_LIST_KEYS


class ConfigError(ValueError):
    """A bad analyzer parameter; the message names it (~analyzers/<ns>/<key>)."""


@dataclass
class Status:
    """A diagnostic_msgs/DiagnosticStatus: values are (key, value) pairs."""
    name: str
    level: int
    message: str = ""
    hardware_id: str = ""
    values: List[Tuple[str, str]] = field(default_factory=list)


def level_message(level: int) -> str:
    """diagnostic_aggregator's valToMsg: a level's word ("Error" for an unknown level)."""
    return LEVEL_MESSAGES.get(level, "Error")


def output_name(item_name: str) -> str:
    """An item's name as a path element: each '/' becomes ' ' (getOutputName)."""
    return item_name.replace("/", " ")


def remove_leading_name_chaff(name: str, chaff: str) -> str:
    """Strip chaff from the start of name's last path element, then a ':' and the
    spaces after it: "/PREFIX/hokuyo: Connection" -> "/PREFIX/Connection" with chaff
    "hokuyo" (removeLeadingNameChaff, including its rule that chaff's first occurrence
    in the whole name must be there)."""
    if not chaff:
        return name
    last = name.rfind("/")
    if last < 0:
        return name[len(chaff):] if name.startswith(chaff) else name
    start = name[:last] + "/"
    if name.find(chaff) == last + 1:
        name = name[:last + 1] + name[last + 1 + len(chaff):]
    if name.find(":", last) == last + 1:
        name = start + name[last + 2:]
    while name.find(" ", last) == last + 1:
        name = start + name[last + 2:]
    return name


def _join(base_path: str, nice_name: str) -> str:
    path = nice_name if base_path == "/" else base_path + "/" + nice_name
    return path if path.startswith("/") else "/" + path


class StatusItem:
    """The latest status of one name, with the time [s] it arrived."""

    def __init__(self, status: Status, now: float):
        self.name = status.name
        self.level = status.level if status.level in LEVEL_MESSAGES else ERROR   # valToLevel
        self.message = status.message
        self.hardware_id = status.hardware_id
        self.values = list(status.values)
        self.update_time = now

    def to_status(self, path: str, stale: bool) -> Status:
        name = ("/" if path == "/" else path + "/") + output_name(self.name)
        return Status(name, STALE if stale else self.level, self.message, self.hardware_id, list(self.values))


def _missing(name: str, now: float) -> StatusItem:
    return StatusItem(Status(name, STALE, "Missing"), now)


class GenericAnalyzerBase:
    """Items by name, reported under path with a header (GenericAnalyzerBase)."""

    def __init__(self, path: str, nice_name: str, timeout: float, num_items: int, discard_stale: bool,
                 now: float):
        self.path, self.nice_name = path, nice_name
        self.timeout, self.num_items = float(timeout), int(num_items)
        # discarding needs a timeout (the real one warns and keeps them)
        self.discard_stale = bool(discard_stale) and self.timeout > 0
        self.items: Dict[str, StatusItem] = {}
        self.last_header_level = OK
        self.last_header_change = now

    def analyze(self, item: StatusItem) -> bool:
        self.items[item.name] = item
        return True

    def report(self, now: float) -> List[Status]:
        header = Status(self.path, OK, "OK")
        out = [header]
        all_stale = True
        for name in sorted(self.items):
            item = self.items[name]
            stale = self.timeout > 0 and now - item.update_time > self.timeout
            if self.discard_stale and stale:
                del self.items[name]
                continue
            header.level = max(header.level, item.level)
            header.values.append((name, item.message))
            all_stale = all_stale and (item.level == STALE or stale)
            out.append(item.to_status(self.path, stale))
            if stale:
                header.level = STALE
        if all_stale:
            header.level = STALE
        elif header.level == STALE:
            header.level = ERROR
        header.message = level_message(header.level)
        if self.num_items == 0 and not self.items:
            header.level, header.message = OK, "OK"
        elif self.num_items > 0 and len(self.items) != self.num_items:
            header.level = max(ERROR, header.level)
            header.message = (f"Expected {self.num_items}, found {len(self.items)}" if self.items
                              else f"No items found, expected {self.num_items}")
        timed_out = self.timeout > 0 and self.last_header_level == STALE and \
            now - self.last_header_change > self.timeout
        if self.last_header_level != header.level:
            self.last_header_change = now
            self.last_header_level = header.level
        if self.discard_stale and len(out) == 1 and timed_out:
            return []
        return out


def _string_list(value, where: str) -> List[str]:
    """A parameter given as a string or a list of strings (getParamVals)."""
    if isinstance(value, str):
        return [value]
    if isinstance(value, list) and all(isinstance(v, str) for v in value):
        return list(value)
    raise ConfigError(f"{where}: must be a string or a list of strings, got {value!r}")


def _number(params: dict, key: str, default, kind, where: str):
    value = params.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float) if kind is float else int):
        raise ConfigError(f"{where}/{key}: must be {'a number' if kind is float else 'an integer'}, "
                          f"got {value!r}")
    return kind(value)


class GenericAnalyzer(GenericAnalyzerBase):
    """GenericAnalyzer from its parameters {path, startswith, contains, name, expected,
    regex, remove_prefix, find_and_remove_prefix, timeout, num_items, discard_stale}.
    where: the parameter namespace, for errors; warn(text) hears unknown keys."""

    def __init__(self, base_path: str, params: dict, where: str, now: float, warn=None):
        nice_name = params.get("path")
        if not isinstance(nice_name, str) or not nice_name:
            raise ConfigError(f"{where}: GenericAnalyzer needs a 'path' (a non-empty string), "
                              f"got {nice_name!r}")
        lists = {k: _string_list(params[k], f"{where}/{k}") for k in STRING_LIST_KEYS if k in params}
        chaff = list(lists.get("find_and_remove_prefix", []))
        self.startswith = list(chaff)
        chaff += lists.get("remove_prefix", [])
        self.startswith += lists.get("startswith", [])
        self.names = lists.get("name", [])
        self.contains = lists.get("contains", [])
        self.expected = lists.get("expected", [])
        self.regex = []
        for pattern in lists.get("regex", []):
            try:
                self.regex.append(re.compile(pattern))
            except re.error as e:
                raise ConfigError(f"{where}/regex: {pattern!r} is not a regular expression: {e}") from None
        if not (self.startswith or self.names or self.contains or self.expected or self.regex):
            raise ConfigError(f"{where}: GenericAnalyzer '{nice_name}' has no way of matching items "
                              "(give startswith, contains, name, expected, regex or find_and_remove_prefix)")
        self.chaff = [output_name(c) for c in chaff]
        unknown = sorted(set(params) - set(GENERIC_KEYS))
        if unknown and warn is not None:
            warn(f"{where}: GenericAnalyzer ignores {', '.join(unknown)}")
        discard = params.get("discard_stale", False)
        if not isinstance(discard, bool):
            raise ConfigError(f"{where}/discard_stale: must be true or false, got {discard!r}")
        super().__init__(_join(base_path, nice_name), nice_name,
                         _number(params, "timeout", DEFAULT_TIMEOUT, float, where),
                         _number(params, "num_items", -1, int, where), discard, now)
        for name in self.expected:
            self.analyze(_missing(name, now))

    def match(self, name: str) -> bool:
        return (any(r.fullmatch(name) for r in self.regex) or name in self.expected or name in self.names
                or any(name.startswith(s) for s in self.startswith) or any(c in name for c in self.contains))

    def report(self, now: float) -> List[Status]:
        out = super().report(now)
        missing = []
        for exp in self.expected:
            found = False
            for status in out:
                nice = status.name[status.name.rfind("/") + 1:]
                if nice == exp or nice == output_name(exp) or \
                        any(nice == remove_leading_name_chaff(exp, c) for c in self.chaff):
                    found = True
                    break
            if not found:
                missing.append(exp)
        all_stale = all(s.level == STALE for s in out)
        out += [_missing(name, now).to_status(self.path, True) for name in missing]
        for status in out:
            for c in self.chaff:
                status.name = remove_leading_name_chaff(status.name, c)
            if missing and status.name == self.path:
                if all_stale:
                    status.level = STALE
                    status.message = "All diagnostics are stale - setting combined level to STALE."
                else:
                    status.level = ERROR
                    status.message = "Some diagnostics are stale - setting combined level to ERROR."
                status.values += [(name, "Missing") for name in missing]
        return out


class AnalyzerGroup:
    """Analyzers under one path (AnalyzerGroup): params {path, analyzers: {ns: {type, ...}}}.
    The aggregator's own top group has no path. errors: the ConfigErrors of analyzers
    that could not be made (each also reported as a Stale status under the path)."""

    def __init__(self, base_path: str, params: dict, where: str, now: float, warn=None):
        nice_name = params.get("path", "")
        if not isinstance(nice_name, str):
            raise ConfigError(f"{where}/path: must be a string, got {nice_name!r}")
        if base_path and base_path != "/":
            path = base_path + "/" + nice_name if nice_name else base_path
        else:
            path = nice_name
        self.path = path if path.startswith("/") else "/" + path
        self.nice_name = nice_name
        self.analyzers = []
        self.errors: List[ConfigError] = []
        self.aux: List[StatusItem] = []
        self.matched: Dict[str, List[bool]] = {}
        where = where + "analyzers" if where.endswith("~") else where + "/analyzers"
        analyzers = params.get("analyzers", {})
        if not isinstance(analyzers, dict):
            raise ConfigError(f"{where}: must be a dict of analyzers {{name: {{type: ..., "
                              f"path: ...}}}}, got {type(analyzers).__name__} {analyzers!r}")
        for ns in sorted(analyzers, key=str):   # the real group's order: its XmlRpc struct's, sorted
            sub = f"{where}/{ns}"
            try:
                self.analyzers.append(make_analyzer(self.path, analyzers[ns], sub, now, warn))
            except ConfigError as e:
                self.errors.append(e)
                self.aux.append(StatusItem(Status(str(ns), STALE, str(e)), now))
            else:
                if isinstance(self.analyzers[-1], AnalyzerGroup):
                    self.errors += self.analyzers[-1].errors
        if not analyzers:
            self.errors.append(ConfigError(f"{where}: no analyzers"))

    def match(self, name: str) -> bool:
        if name not in self.matched:
            self.matched[name] = [a.match(name) for a in self.analyzers]
        return any(self.matched[name])

    def analyze(self, item: StatusItem) -> bool:
        analyzed = False
        for analyzer, hit in zip(self.analyzers, self.matched[item.name]):
            if hit:
                analyzed = analyzer.analyze(item) or analyzed
        return analyzed

    def report(self, now: float) -> List[Status]:
        header = Status(self.path, OK, "OK")
        if not self.analyzers:
            header.level, header.message = ERROR, "No analyzers"
            if header.name in ("", "/"):
                header.name = "/AnalyzerGroup"
            return [header] + [a.to_status(self.path, True) for a in self.aux]
        out = []
        all_stale = True
        for analyzer in self.analyzers:
            for status in analyzer.report(now):
                out.append(status)
                if status.name == analyzer.path:
                    header.values.append((analyzer.nice_name, status.message))
                    all_stale = all_stale and status.level == STALE
                    header.level = max(header.level, status.level)
        if header.level == STALE and not all_stale:
            header.level = ERROR
        header.message = level_message(header.level)
        if self.path not in ("", "/"):
            out.append(header)
        return out + [a.to_status(self.path, True) for a in self.aux]


def make_analyzer(base_path: str, params, where: str, now: float, warn=None):
    """A GenericAnalyzer or AnalyzerGroup from its parameters; ConfigError naming where."""
    if not isinstance(params, dict):
        raise ConfigError(f"{where}: must be a dict with a 'type', got {params!r}")
    kind = params.get("type")
    if kind is None:
        raise ConfigError(f"{where}: no 'type' (e.g. diagnostic_aggregator/GenericAnalyzer)")
    if kind in GENERIC_TYPES:
        return GenericAnalyzer(base_path, params, where, now, warn)
    if kind in GROUP_TYPES:
        return AnalyzerGroup(base_path, params, where, now, warn)
    raise ConfigError(f"{where}: unknown type {kind!r} (supported: {GENERIC_TYPES[0]}, {GROUP_TYPES[0]})")


class OtherAnalyzer(GenericAnalyzerBase):
    """What no analyzer matched, under <base_path>/Other; dropped when stale."""

    def __init__(self, base_path: str, other_as_errors: bool, now: float):
        super().__init__(base_path + "/Other", "Other", OTHER_TIMEOUT, -1, True, now)
        self.other_as_errors = other_as_errors

    def report(self, now: float) -> List[Status]:
        out = super().report(now)
        if len(out) <= 1:
            return []
        if self.other_as_errors:
            out[0].level, out[0].message = ERROR, 'Unanalyzed items found in "Other"'
        return out


class Aggregator:
    """The aggregator's state. params: the node's private parameters (analyzers,
    base_path, other_as_errors); add(statuses, now) for each /diagnostics message;
    report(now) -> (statuses for /diagnostics_agg, the toplevel_state Status). A bad
    base_path, other_as_errors or analyzers (not a dict) raises ConfigError; a bad
    analyzer inside is in `errors`."""

    def __init__(self, params: dict, now: float, warn=None):
        base_path = params.get("base_path", "")
        if not isinstance(base_path, str):
            raise ConfigError(f"~base_path: must be a string, got {base_path!r}")
        other_as_errors = params.get("other_as_errors", False)
        if not isinstance(other_as_errors, bool):
            raise ConfigError(f"~other_as_errors: must be true or false, got {other_as_errors!r}")
        if base_path and not base_path.startswith("/"):
            base_path = "/" + base_path
        self.base_path = base_path
        analyzers = params.get("analyzers", {})
        self.group = AnalyzerGroup(base_path, {"analyzers": analyzers}, "~", now, warn)
        self.other = OtherAnalyzer(base_path, other_as_errors, now)

    @property
    def errors(self) -> List[ConfigError]:
        return self.group.errors

    def add(self, statuses, now: float) -> None:
        for status in statuses:
            item = StatusItem(status, now)
            if not (self.group.match(item.name) and self.group.analyze(item)):
                self.other.analyze(item)

    def report(self, now: float) -> Tuple[List[Status], Status]:
        out = self.group.report(now) + self.other.report(now)
        top = Status("toplevel_state", -1, "")
        if out:
            levels = [s.level for s in out]
            top.level = max(levels)
            if top.level > ERROR and min(levels) <= ERROR:
                top.level = ERROR
        return out, top
