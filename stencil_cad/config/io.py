"""Read a job config from YAML with one-line errors, and write the commented default config."""

from __future__ import annotations

import json
import logging
import re
import textwrap
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml
from pydantic import BaseModel, ValidationError

from ..errors import ConfigError
from ..files import TEXT_LIMIT, read_text

log = logging.getLogger(__name__)

#: Longest quotation of a bad value in an error message, in characters.
QUOTE_CHARS = 200

#: Most values a config may hold once YAML aliases are expanded (an alias bomb is a few
#: lines that expand to billions).
MAX_VALUES = 100_000

#: Deepest nesting of mappings and lists a config, profile or card description may have.
MAX_DEPTH = 32


def short_repr(value: Any, limit: int = QUOTE_CHARS) -> str:
    """``repr`` of a value, cut to ``limit`` characters in bounded time (shared sub-trees too)."""
    import reprlib

    r = reprlib.Repr()
    r.maxlevel, r.maxdict, r.maxlist, r.maxtuple, r.maxset = 3, 8, 8, 8, 8
    r.maxstring, r.maxother, r.maxlong = limit, limit, limit
    text = r.repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


class _StrictLoader(yaml.SafeLoader):
    """PyYAML's safe loader that also refuses duplicate keys."""

    def construct_mapping(self, node, deep=False):
        if isinstance(node, yaml.MappingNode):
            seen: dict = {}
            for key_node, _ in node.value:
                try:
                    key = self.construct_object(key_node, deep=True)
                    hash(key)
                except (TypeError, yaml.YAMLError):
                    continue
                if key in seen:
                    raise yaml.constructor.ConstructorError(
                        None,
                        None,
                        f"duplicate key {short_repr(key)} (first at line {seen[key] + 1}; keep one of them)",
                        key_node.start_mark,
                    )
                seen[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def _count_values(data: Any, budget: int) -> tuple[int, int]:
    """Values in a loaded document counted with repetition, stopping past ``budget``; and its depth."""
    stack, n, depth = [(data, 1)], 0, 0
    while stack:
        item, d = stack.pop()
        n += 1
        depth = max(depth, d)
        if n > budget or depth > MAX_DEPTH:
            break
        if isinstance(item, dict):
            stack.extend((k, d + 1) for k in item.keys())
            stack.extend((v, d + 1) for v in item.values())
        elif isinstance(item, (list, tuple)):
            stack.extend((v, d + 1) for v in item)
    return n, depth


def _check_bounds(data: Any, source: str) -> None:
    n, depth = _count_values(data, MAX_VALUES)
    if n > MAX_VALUES:
        raise ConfigError(
            f"{source}: the file expands to more than {MAX_VALUES} values (YAML aliases nested too "
            "deep?); write the values out"
        )
    if depth > MAX_DEPTH:
        raise ConfigError(
            f"{source}: mappings and lists nested more than {MAX_DEPTH} deep; a stencil-cad file is "
            "a few levels deep (see templates/default.yaml)"
        )


def read_yaml_text(path: Path, what: str, fix: str) -> str:
    """The text of a config, profile or card description: a regular UTF-8 file of at most 1 MiB.

    Raises:
        ConfigError: Missing, not a regular file (a FIFO, a device), too large or not text.
    """
    return read_text(path, what, limit=TEXT_LIMIT, error=ConfigError, fix=fix)


def parse_yaml(text: str, source: str) -> Any:
    """Parse config YAML: safe types only, no duplicate keys, bounded size.

    Raises:
        ConfigError: Syntax error, unsupported tag, duplicate key or an expansion too large.
    """
    if len(text) > TEXT_LIMIT:
        raise ConfigError(f"{source}: more than {TEXT_LIMIT} characters; a config is a short YAML file")
    try:
        data = yaml.load(text, Loader=_StrictLoader)  # noqa: S506 - a SafeLoader subclass
    except RecursionError:
        raise ConfigError(
            f"{source}: mappings and lists nested too deep; a stencil-cad file is a few levels deep"
        ) from None
    except yaml.constructor.ConstructorError as exc:
        mark = exc.problem_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = str(exc.problem or "")
        if "could not determine a constructor for the tag" in problem:
            tag = problem.split("tag", 1)[1].strip().strip("'")
            tag = tag.replace("tag:yaml.org,2002:", "!!")
            raise ConfigError(
                f"{source}: unsupported tag {tag[:100]}{where} (a config is plain YAML: values, lists and "
                "mappings; remove the tag)"
            ) from None
        raise ConfigError(f"{source}{where}: {problem[: QUOTE_CHARS * 2]}") from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(
            f"{source}: YAML syntax error{where}: {str(problem)[:QUOTE_CHARS]} (fix the indentation or "
            "quoting there)"
        ) from None
    _check_bounds(data, source)
    return data


def parse_json(text: str, source: str) -> Any:
    """Parse a JSON file the tool wrote (``card.json``): no duplicate keys, NaN or infinity, bounded.

    Raises:
        ConfigError: Syntax error, duplicate key, a non-finite number, or too large or deep.
    """

    def pairs(items: list[tuple[str, Any]]) -> dict:
        out: dict = {}
        for key, value in items:
            if key in out:
                raise ValueError(f"duplicate key {short_repr(key)} (keep one of them)")
            out[key] = value
        return out

    def constant(name: str) -> Any:
        raise ValueError(f"{name} is not a number stencil-cad accepts (write a finite number)")

    if len(text) > TEXT_LIMIT:
        raise ConfigError(f"{source}: more than {TEXT_LIMIT} characters; not a file stencil-cad wrote")
    try:
        data = json.loads(text, object_pairs_hook=pairs, parse_constant=constant)
    except RecursionError:
        raise ConfigError(f"{source}: objects and arrays nested too deep") from None
    except ValueError as exc:
        raise ConfigError(
            f"{source}: not valid JSON: {str(exc)[:QUOTE_CHARS]} (fix or rewrite the file)"
        ) from None
    _check_bounds(data, source)
    return data


_UNION_TAG = re.compile(
    r"^(float|int|bool|str|none|enum|function-.*|union\[.*|nullable\[.*|list\[.*|tuple\[.*|dict\[.*|"
    r"is-instance\[.*|literal\[.*|constrained-.*|lax-or-strict.*|json-or-python.*|chain\[.*|"
    r"function-(after|before|wrap|plain)\[.*)$"
)

if TYPE_CHECKING:
    from . import JobConfig


def _format_loc(loc: tuple) -> str:
    parts: list[str] = []
    for item in loc:
        if isinstance(item, int):
            parts.append(f"[{item}]")
        elif item in ("function-after", "function-before") or _UNION_TAG.match(str(item)):
            continue  # pydantic's names of union branches and validators, not config keys
        else:
            text = str(item)
            if not re.fullmatch(r"[A-Za-z0-9_\-]+", text):
                text = short_repr(text, 40)  # a key with spaces or control characters, quoted
            parts.append(("." if parts else "") + text)
    return "".join(parts) or "(top level)"


def format_validation_error(exc: ValidationError, source: str = "config") -> str:
    """Turn a pydantic error into one line: dotted path, bad value, what is allowed.

    The first problem is described in full; further problems (other keys) are counted and
    named by path, so the message stays one line however many keys are wrong.

    Args:
        exc: The pydantic error.
        source: Name of the config file, for the message.

    Returns:
        The one-line message.
    """
    first: dict[str, str] = {}
    for err in exc.errors(include_url=False):
        loc = _format_loc(tuple(err.get("loc", ())))
        if loc in first:
            continue  # a union reports each branch at the same place: the first says enough
        msg = err.get("msg", "invalid")
        if msg.startswith("Value error, "):
            msg = msg[len("Value error, ") :]
        msg = " ".join(msg.split())
        msg = msg if len(msg) <= 2 * QUOTE_CHARS else msg[: 2 * QUOTE_CHARS] + "…"
        kind = err.get("type", "")
        if kind == "extra_forbidden":
            first[loc] = (
                f"{source}: {loc}: unknown key (check the spelling; `stencil-cad init` writes every valid key)"
            )
            continue
        value = err.get("input")
        shown = (
            ""
            if kind == "missing" or isinstance(value, dict) or "got " in msg
            else f", got {short_repr(value)}"
        )
        first[loc] = f"{source}: {msg}" if loc == "(top level)" else f"{source}: {loc}: {msg}{shown}"
    lines = list(first.values())
    if len(lines) > 1:
        others = [loc for loc in first][1:]
        more = ", ".join(others[:5]) + (", …" if len(others) > 5 else "")
        return f"{lines[0]} (and {len(others)} more: {more})"
    return lines[0] if lines else f"{source}: invalid config"


def parse_config(data: Any, source: str = "config") -> JobConfig:
    """Validate a mapping into a :class:`JobConfig`.

    Raises:
        ConfigError: With the dotted path, the bad value and what is allowed.
    """
    from . import JobConfig

    if data is None:
        raise ConfigError(f"{source}: the config is empty (write one with `stencil-cad init config.yaml`)")
    if not isinstance(data, dict):
        raise ConfigError(
            f"{source}: the config must be a mapping of keys to values, got a {type(data).__name__} "
            "(see templates/default.yaml)"
        )
    try:
        return JobConfig.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, source)) from None


def load_config(path: Path | str) -> JobConfig:
    """Read and validate a YAML config file.

    A relative ``image`` path is resolved against the config file's folder.

    Args:
        path: The YAML file.

    Returns:
        The validated :class:`JobConfig`.

    Raises:
        ConfigError: Missing file, YAML syntax error, empty file or invalid content.
    """
    path = Path(path)
    text = read_yaml_text(path, "config", "give a YAML file; `stencil-cad init FILE` writes one")
    data = parse_yaml(text, str(path))
    _commented_keys(text, data, str(path))
    return resolve_files(parse_config(data, source=str(path)), data, path.parent, str(path))


def resolve_files(cfg: JobConfig, data: Any, folder: Path, source: str = "config") -> JobConfig:
    """Take the files a config names (image, can lists, plate template, spray profiles) from ``folder`` and read the profiles.

    :func:`load_config` does this with the config file's folder; a config made from a mapping in
    code (``stencil_cad.api.load_config``) with the working folder.

    Args:
        cfg: The config parsed from ``data``.
        data: The mapping it was parsed from (the profile's checks read the raw ``spray`` keys).
        folder: Folder relative paths are taken from.
        source: What the config came from, for messages.

    Raises:
        ConfigError: A profile cannot be read, a plate template is missing or not a ``.py`` file.
    """
    if cfg.image is not None and not cfg.image.is_absolute():
        cfg = cfg.model_copy(update={"image": (folder / cfg.image)})
    cfg = _resolve_can_lists(cfg, folder)
    if cfg.plate.template is not None and not cfg.plate.template.is_absolute():
        plate = cfg.plate.model_copy(update={"template": folder / cfg.plate.template})
        cfg = cfg.model_copy(update={"plate": plate})
    if cfg.spray.profile is not None:
        raw = (data.get("spray") if isinstance(data, dict) else None) or {}
        cfg = with_profile(cfg, folder, raw.get("can"), source=source, raw_layer_cans=raw.get("layer_cans"))
    if cfg.plate.template is not None and not cfg.plate.template.is_file():
        raise ConfigError(
            f"{source}: plate.template: file not found: {cfg.plate.template} (copy templates/plate.py there, "
            "or remove the key to use the built-in template)"
        )
    if cfg.plate.template is not None and cfg.plate.template.suffix != ".py":
        raise ConfigError(
            f"{source}: plate.template: {cfg.plate.template} is not a Python file (a template is a .py file "
            "like templates/plate.py; it is Python code and runs with your rights)"
        )
    return cfg


#: A line whose first text is an unquoted hex colour key: YAML reads it as a comment.
_HEX_KEY_LINE = re.compile(r"^\s*(#[0-9a-fA-F]{6}|#[0-9a-fA-F]{3})\s*:(.*)$")


def _commented_keys(text: str, data: Any, source: str) -> None:
    """Name an unquoted ``#rrggbb:`` key, which YAML reads as a comment (the mapping loses it).

    Raises:
        ConfigError: ``spray.profile`` is null while such a line is in the file (its mapping's
            keys were all read as comments).
    """
    hits = [
        (n, m.group(1), m.group(2).strip())
        for n, line in enumerate(text.splitlines(), 1)
        if (m := _HEX_KEY_LINE.match(line))
    ]
    if not hits:
        return
    n, key, value = hits[0]
    quoted = f'"{key}": {value}' if value else f'"{key}": ...'
    spray = data.get("spray") if isinstance(data, dict) else None
    if isinstance(spray, dict) and "profile" in spray and spray["profile"] is None:
        raise ConfigError(
            f"{source}: spray.profile is empty (null) because line {n}, `{key}: {value}`, is a YAML comment: a "
            f"key starting with # must be quoted; write {quoted}"
        )
    for n, key, value in hits:
        log.warning(
            '%s: line %d, `%s: %s`, is a YAML comment and is ignored; if it is a paint\'s key, quote it: "%s"',
            source,
            n,
            key,
            value,
            key,
        )


def load_profile(path: Path | str):
    """Read a spray profile (the file `stencil-cad calibrate` writes) into :class:`CanConstants`.

    Raises:
        ConfigError: Missing or unreadable file, or invalid content (with the key's path).
    """
    from .spray import CanConstants

    path = Path(path)
    text = read_yaml_text(
        path, "spray profile", "write one with `stencil-cad calibrate PHOTO --card card.json`"
    )
    data = parse_yaml(text, str(path))
    if not isinstance(data, dict):
        raise ConfigError(
            f"{path}: a spray profile is a mapping of keys to values (see `stencil-cad calibrate`)"
        )
    try:
        return CanConstants.model_validate(data)
    except ValidationError as exc:
        raise ConfigError(format_validation_error(exc, str(path))) from None


def with_profile(cfg, folder: Path, raw_can: Any = None, source: str = "config", raw_layer_cans: Any = None):
    """Resolve ``spray.profile`` (relative to ``folder``) and put its constants into the spray section.

    One file's constants go to ``spray.can``; a mapping's ``default`` file's too, and every other
    file's to ``spray.layer_cans`` under its key.

    Args:
        cfg: The validated job config.
        folder: Folder a relative profile path is taken from (the config file's).
        raw_can: The ``spray.can`` mapping as written in the file, if any: it must not
            contradict the profile.
        source: Name of the config, for messages.
        raw_layer_cans: The ``spray.layer_cans`` mapping as written, if any: it must not
            contradict the files.

    Returns:
        The config with ``spray.profile`` absolute and ``spray.can`` (and ``spray.layer_cans``) from
        the files.

    Raises:
        ConfigError: A profile cannot be read, or ``spray.can`` or ``spray.layer_cans`` says something else.
    """
    from .profiles import DEFAULT_KEY

    sp = cfg.spray
    paths = sp.profile if isinstance(sp.profile, dict) else {DEFAULT_KEY: sp.profile}
    paths = {k: (p if p.is_absolute() else folder / p) for k, p in paths.items()}
    cans = {}
    for key, p in paths.items():
        try:
            cans[key] = load_profile(p)
        except ConfigError as exc:
            if not isinstance(sp.profile, dict):
                raise
            raise ConfigError(f"{source}: spray.profile: key {key!r}: {exc}") from None
    if raw_can is not None and DEFAULT_KEY in cans and _as_can(raw_can) != cans[DEFAULT_KEY]:
        raise ConfigError(
            f"{source}: spray.can and spray.profile both set and they differ: remove spray.can "
            "(the profile's constants are used) or remove spray.profile"
        )
    layer_cans = {k: c for k, c in cans.items() if k != DEFAULT_KEY}
    if raw_layer_cans:
        for key, written in sp.layer_cans.items():
            if written != layer_cans.get(key):
                raise ConfigError(
                    f"{source}: spray.layer_cans: key {key!r} differs from its file {paths[key].name}: remove "
                    "spray.layer_cans (it is filled from spray.profile's files)"
                )
    update: dict[str, Any] = {"profile": paths if isinstance(sp.profile, dict) else paths[DEFAULT_KEY]}
    if DEFAULT_KEY in cans:
        update["can"] = cans[DEFAULT_KEY]
    if isinstance(sp.profile, dict):
        update["layer_cans"] = layer_cans
    return cfg.model_copy(update={"spray": sp.model_copy(update=update)})


def _as_can(raw: Any):
    """``spray.can`` as written, validated (None when it is not a valid can)."""
    from .spray import CanConstants

    try:
        return CanConstants.model_validate(raw)
    except ValidationError:
        return None


def _resolve_can_lists(cfg, folder: Path):
    """Can-list paths (palettes as CSV, the paint catalogue) are taken from the config's folder."""

    def fix(p):
        return p if not isinstance(p, Path) or p.is_absolute() else folder / p

    dec = cfg.decompose.model_copy(update={"palette": fix(cfg.decompose.palette)})
    hard = cfg.hard.model_copy(update={"palette": fix(cfg.hard.palette)})
    paints = cfg.paints.model_copy(update={"catalogue": fix(cfg.paints.catalogue)})
    return cfg.model_copy(update={"decompose": dec, "hard": hard, "paints": paints})


def _yaml_scalar(value: Any) -> str:
    if isinstance(value, (dict, list)):
        return json.dumps(value)
    dumped = yaml.safe_dump(value, default_flow_style=True, allow_unicode=True).strip()
    if dumped.endswith("\n..."):
        dumped = dumped[: -len("\n...")]
    return dumped.removesuffix("...").strip()


def _comment(text: str, indent: str) -> list[str]:
    return [f"{indent}# {line}" for line in textwrap.wrap(text, width=96 - len(indent))]


def _emit(model_cls: type[BaseModel], values: dict, indent: str) -> list[str]:
    lines: list[str] = []
    for name, field in model_cls.model_fields.items():
        desc = field.description or ""
        value = values.get(name)
        ann = field.annotation
        sub = ann if isinstance(ann, type) and issubclass(ann, BaseModel) else None
        lines.extend(_comment(desc, indent))
        if sub is not None and isinstance(value, dict) and value:
            lines.append(f"{indent}{name}:")
            lines.extend(_emit(sub, value, indent + "  "))
        else:
            lines.append(f"{indent}{name}: {_yaml_scalar(value)}")
        if not indent:
            lines.append("")
    return lines


def default_yaml() -> str:
    """The commented default config: every key, with its unit, range and choices.

    ``templates/default.yaml`` is this text (a test keeps them equal) and
    ``stencil-cad init`` writes it.
    """
    from . import JobConfig

    values = JobConfig().model_dump(mode="json")
    # Filled in from stipple.process when left out: the template leaves it to the process. (The
    # plate's label, thickness and margin stay null in a config: the plan fills them in.)
    values["spray"]["nozzle_height"] = None
    values["wall"]["standoff_mm"] = None
    head = [
        "# stencil_cad job config. Every key is optional; the values below are the defaults.",
        "# Run it with:  stencil-cad run this.yaml   (editors: `stencil-cad schema` prints a JSON Schema)",
        "",
    ]
    return "\n".join(head + _emit(JobConfig, values, "")).rstrip() + "\n"


def json_schema() -> dict:
    """JSON Schema of the config, for editor completion."""
    from . import JobConfig

    schema = JobConfig.model_json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "stencil_cad job config"
    return schema
