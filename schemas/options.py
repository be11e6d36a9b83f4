"""Command-line options derived from a configuration model: each option is written once.

A field of a frozen pydantic model carries an `Option` in its ``Annotated`` metadata (flag,
group, help); its type, default, choices and bounds come from the field itself. From that one
definition `add_options` builds the argparse arguments (grouped by concern in ``--help``),
`config_values` turns the parsed arguments back into the model's fields, `invalid_options`
names the option of each field the model refused, and `passed_through` spells parsed
options again for another process (``riverbridge up`` starting the bridge). Bounds are
checked as the text is read, so a bad value is named with its option and argparse exits 2.
"""

from __future__ import annotations

import argparse
import operator
import types
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Union, get_args, get_origin

from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

MIB = 1024 * 1024  # shown as "64 MiB" in --help
_TRUE = {"1", "true", "yes", "on"}
_FALSE = {"", "0", "false", "no", "off"}


@dataclass(frozen=True)
class Option:
    """How a model field is spelled on the command line (put it in the field's Annotated)."""

    flag: str
    group: str
    help: str
    metavar: str | None = None
    env: str | None = None  # environment variable giving the default; the option wins
    many: Literal["append", "extend"] | None = None  # tuple fields: --x a --x b, or --x a b
    split: str | None = None  # one value may list several, separated by this
    negate: bool = False  # a bool field the bare flag sets to False
    paired: bool = False  # a bool field with both --flag and --no-flag (argparse's pair)
    exists: Literal["file", "dir"] | None = None  # a path that must exist (then resolved)
    read: Callable[[Path], Any] | None = None  # the field's value from that path (a secret)


@dataclass(frozen=True)
class SpelledOption:
    """One field's option with what the field says about its values."""

    name: str
    option: Option
    field: FieldInfo
    kind: Any  # the type of one value: int, float, str, Path, bool, or a Literal

    @property
    def switch(self) -> bool:
        return self.kind is bool

    def choices(self) -> tuple[str, ...] | None:
        return get_args(self.kind) if get_origin(self.kind) is Literal else None

    def text_value(self, text: str) -> Any:
        """One value read from its text, bounds checked (ArgumentTypeError says why not)."""
        value = self.passed_value(text)
        if self.option.read is None:
            return value
        try:
            return self.option.read(value)
        except ValueError as exc:  # a file that does not read: its own words name the field
            raise argparse.ArgumentTypeError(str(exc)) from None

    def passed_value(self, text: str) -> Any:
        """`text_value`, but a path to read stays the (checked) path: for another process."""
        if self.kind is int or self.kind is float:
            return self._number(text)
        if self.option.exists is not None:
            return self._existing(text)
        if self.kind is Path:
            return Path(text)
        return text

    def _number(self, text: str) -> int | float:
        try:
            value = self.kind(text)
        except ValueError:
            what = "an integer" if self.kind is int else "a number"
            raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None
        if not all(_within(bound, value) for bound in self.field.metadata):
            raise argparse.ArgumentTypeError(f"must be {self.bounds()}, got {text}")
        return value  # type: ignore[no-any-return]

    def bounds(self) -> str:
        """The field's bounds in words: "a positive integer", "0..65535", "at least 65536"."""
        found = {type(b).__name__: _limit(b) for b in self.field.metadata if _limit(b) is not None}
        unit = " bytes" if self.name.endswith("_bytes") else ""
        if found.get("Gt") == 0:
            return "a positive integer" if self.kind is int else "a positive number"
        if "Ge" in found and "Le" in found:
            return f"{found['Ge']}..{found['Le']}"
        if "Ge" in found:
            return f"at least {found['Ge']}{unit}"
        return ", ".join(f"{kind.lower()} {limit}" for kind, limit in found.items())

    def _existing(self, text: str) -> Path:
        path = Path(text)
        if self.option.exists == "dir" and not path.is_dir():
            raise argparse.ArgumentTypeError(f"{text} is not a directory")
        if self.option.exists == "file" and not path.is_file():
            raise argparse.ArgumentTypeError(f"no such file: {text}")
        return path.resolve()

    def env_default(self, env: Mapping[str, str]) -> Any:
        """The default the environment gives, or the field's (ValueError names the variable)."""
        text = env.get(self.option.env, "").strip() if self.option.env else ""
        if not text:
            return self.field.default
        try:
            if self.switch:
                return _switch_text(text)
            values = [self.text_value(part) for part in self.parts([text])]
        except (argparse.ArgumentTypeError, ValueError) as exc:
            raise ValueError(f"{self.option.env} {exc}") from None
        return tuple(values) if self.option.many else values[0]

    def parts(self, texts: Iterable[str]) -> list[str]:
        """The values of repeated arguments, each split on `Option.split`."""
        if self.option.split is None:
            return list(texts)
        return [p.strip() for t in texts for p in t.split(self.option.split) if p.strip()]

    def help_text(self) -> str:
        shown = _shown_default(self.field.default)
        notes = [f"default {shown}"] if shown is not None else []
        notes += [f"${self.option.env}"] if self.option.env else []
        return f"{self.option.help} ({'; '.join(notes)})" if notes else self.option.help


# pydantic keeps a field's bounds as annotated_types' Gt, Ge, Lt, Le objects in its metadata.
_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "Gt": operator.gt,
    "Ge": operator.ge,
    "Lt": operator.lt,
    "Le": operator.le,
}


def _limit(bound: object) -> object:
    """The number of a Gt/Ge/Lt/Le bound, None for other metadata."""
    kind = type(bound).__name__
    return getattr(bound, kind.lower(), None) if kind in _COMPARE else None


def _within(bound: object, value: float) -> bool:
    kind = type(bound).__name__
    return kind not in _COMPARE or _COMPARE[kind](value, _limit(bound))


def _switch_text(text: str) -> bool:
    flag = text.lower()
    if flag not in _TRUE | _FALSE:
        raise ValueError(f"must be 1/0, true/false, yes/no, got {text!r}")
    return flag in _TRUE


def _shown_default(default: Any) -> str | None:
    if default is None or default == () or default == "" or isinstance(default, bool):
        return None
    if isinstance(default, int) and default >= MIB and default % MIB == 0:
        return f"{default // MIB} MiB"
    return str(default)


def _one_value_type(annotation: Any) -> Any:
    """`int | None` -> int, `tuple[Annotated[str, ...], ...]` -> str, SecretStr stays."""
    origin = get_origin(annotation)
    if origin in (Union, types.UnionType):
        (kind,) = [a for a in get_args(annotation) if a is not type(None)]
        return _one_value_type(kind)
    if origin is tuple:
        return _one_value_type(get_args(annotation)[0])
    if origin is not None and origin is not Literal:  # Annotated[str, ...]
        return _one_value_type(get_args(annotation)[0])
    return annotation


def spelled(model: type[BaseModel], names: Sequence[str] | None = None) -> list[SpelledOption]:
    """The fields of `model` that have an option (those of `names`, in that order)."""
    found = {}
    for name, field in model.model_fields.items():
        option = next((m for m in field.metadata if isinstance(m, Option)), None)
        if option is not None:
            found[name] = SpelledOption(name, option, field, _one_value_type(field.annotation))
    return [found[n] for n in names] if names is not None else list(found.values())


class _Many(argparse.Action):
    """Repeatable values; given ones replace the default (from the environment) instead of
    adding to it. The default is a tuple, what the command line gave a list."""

    def __call__(
        self,
        parser: argparse.ArgumentParser,
        namespace: argparse.Namespace,
        values: Any,
        option_string: str | None = None,
    ) -> None:
        given = getattr(namespace, self.dest, None)
        given = given if isinstance(given, list) else []
        given.extend(values if isinstance(values, list) else [values])
        setattr(namespace, self.dest, given)


def add_options(
    parser: argparse.ArgumentParser,
    model: type[BaseModel],
    groups: Sequence[str],
    names: Sequence[str] | None = None,
    env: Mapping[str, str] | None = None,
    passing: str = "",
) -> None:
    """Add `model`'s options (those of `names`) to `parser` in `groups` (in that order).

    `env` gives defaults to options that name a variable. With `passing` (a note for the
    group titles: " (passed to the bridge)") the options are read for another process:
    nothing is given unless the command line gives it.
    """
    sections = {title: parser.add_argument_group(title + passing) for title in groups}
    for spell in spelled(model, names):
        default = spell.field.default
        if not passing:
            try:
                default = spell.env_default(env or {})
            except ValueError as exc:
                parser.error(str(exc))
        _add(sections[spell.option.group], spell, default, bool(passing))


def _add(group: argparse._ArgumentGroup, spell: SpelledOption, default: Any, passing: bool) -> None:
    """One argument; with `passing` its default is "not given" (None, (), the bare switch's
    opposite) and paths to read stay paths."""
    option = spell.option
    if spell.switch and option.paired:
        group.add_argument(
            option.flag,
            dest=spell.name,
            action=argparse.BooleanOptionalAction,
            default=None if passing else default,
            help=spell.help_text(),
        )
        return
    if spell.switch:
        group.add_argument(
            option.flag,
            dest=spell.name,
            action="store_false" if option.negate else "store_true",
            default=default if not passing else option.negate,
            help=spell.help_text(),
        )
        return
    kwargs: dict[str, Any] = {"dest": spell.name, "help": spell.help_text()}
    kwargs["default"] = (() if option.many else None) if passing else default
    if spell.choices():
        kwargs["choices"] = spell.choices()
    else:
        kwargs["type"] = spell.passed_value if passing else spell.text_value
        kwargs["metavar"] = option.metavar
    if option.many:
        kwargs.update(action=_Many, nargs="+" if option.many == "extend" else None)
    group.add_argument(option.flag, **kwargs)


def config_values(
    args: argparse.Namespace, model: type[BaseModel], names: Sequence[str] | None = None
) -> dict[str, Any]:
    """The model's fields as the parsed `args` give them."""
    values = {}
    for spell in spelled(model, names):
        value = getattr(args, spell.name)
        if spell.option.many:
            value = tuple(spell.parts(value)) if isinstance(value, list) else tuple(value)
        values[spell.name] = value
    return values


def passed_through(
    args: argparse.Namespace, model: type[BaseModel], names: Sequence[str]
) -> tuple[str, ...]:
    """The options of `names` that `args` (parsed with `passing`) gives, spelled again."""
    argv: list[str] = []
    for name, value in config_values(args, model, names).items():
        option = spell_of(model, name).option
        if isinstance(value, bool) and option.paired:
            argv += [option.flag if value else "--no-" + option.flag.removeprefix("--")]
        elif isinstance(value, bool):
            argv += [option.flag] if value != option.negate else []
        elif isinstance(value, tuple):
            if option.many == "extend" and value:
                argv += [option.flag, *map(str, value)]
            else:
                argv += [item for v in value for item in (option.flag, str(v))]
        elif value is not None:
            argv += [option.flag, str(value)]
    return tuple(argv)


def spell_of(model: type[BaseModel], name: str) -> SpelledOption:
    (found,) = spelled(model, [name])
    return found


def invalid_options(exc: ValidationError, model: type[BaseModel]) -> str:
    """What the model refused, each field named by its option: "argument --x: x ..."."""
    flags = {s.name: s.option.flag for s in spelled(model)}
    lines = []
    for error in exc.errors():
        field = str(error["loc"][0]) if error["loc"] else ""
        where = f"argument {flags[field]}: {field}: " if field in flags else ""
        shown = error.get("input")
        given = f", got {shown!r}" if field and not isinstance(shown, dict) else ""
        lines.append(f"{where}{error['msg']}{given}")
    return "; ".join(lines)


__all__ = [
    "Option",
    "SpelledOption",
    "add_options",
    "config_values",
    "invalid_options",
    "passed_through",
    "spelled",
]
