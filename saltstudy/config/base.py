"""What every configuration record shares: frozen, strict pydantic models, their content hash, and
their validation from a dict (a file's data, or a record with changes deep-merged in: ``replace``)
with errors that name the field and the reason."""
from __future__ import annotations

import hashlib
import json
from typing import Any

from pydantic import BaseModel, ConfigDict, ValidationError

from .files import ConfigError

# Horizontal area of the paper's domain (20 m x 15 m, section 2.4): the initial release of 10 000
# parcels is per this area.
PAPER_AREA_M2 = 20.0 * 15.0


class Frozen(BaseModel):
    """A record that cannot change once validated and refuses unknown keys."""
    model_config = ConfigDict(frozen=True, extra="forbid", validate_default=True)

    def replace(self, **changes: Any) -> Any:
        """A validated copy with ``changes`` deep-merged in (a section takes a dict of the fields
        that change, a list is replaced whole): ``case.replace(forcing={"u_star_s": 0.47})``.
        Raises ConfigError naming the field (pydantic's ``model_copy(update=...)`` validates
        nothing)."""
        new = validate_model(type(self), deep_merge(self.model_dump(), changes),
                             f"{type(self).__name__}.replace")
        for name, value in (self.__pydantic_private__ or {}).items():   # a study's file
            setattr(new, name, value)
        return new


def content_hash(model: BaseModel | dict[str, Any], length: int = 16) -> str:
    """Stable SHA-256 of a model's JSON dump (independent of PYTHONHASHSEED and key order)."""
    data = model.model_dump(mode="json") if isinstance(model, BaseModel) else model
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:length]


def deep_merge(base: dict[str, Any], update: dict[str, Any]) -> dict[str, Any]:
    """Recursive dict merge (update wins); lists and scalars are replaced."""
    out = dict(base)
    for k, v in update.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def _format_errors(err: ValidationError, source: str) -> str:
    lines = [f"{source}: invalid configuration"]
    for e in err.errors():
        loc = ".".join(str(p) for p in e["loc"]) or "(top level)"
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            msg = "unknown key (not a field of this section)"
        lines.append(f"  {loc}: {msg}")
    return "\n".join(lines)


def validate_model(cls: type[BaseModel], data: dict[str, Any], source: str) -> Any:
    try:
        return cls.model_validate(data)
    except ValidationError as err:
        raise ConfigError(_format_errors(err, source)) from None
