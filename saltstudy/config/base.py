"""What every configuration record shares: frozen, strict pydantic models and their content hash."""
from __future__ import annotations

import hashlib
import json
from typing import Any

from pydantic import BaseModel, ConfigDict

__all__ = ["Frozen", "content_hash", "PAPER_AREA_M2"]

# Horizontal area of the paper's domain (20 m x 15 m, section 2.4): the initial release of 10 000
# parcels is per this area.
PAPER_AREA_M2 = 20.0 * 15.0


class Frozen(BaseModel):
    """A record that cannot change once validated and refuses unknown keys."""
    model_config = ConfigDict(frozen=True, extra="forbid", validate_default=True)


def content_hash(model: BaseModel | dict[str, Any], length: int = 16) -> str:
    """Stable SHA-256 of a model's JSON dump (independent of PYTHONHASHSEED and key order)."""
    data = model.model_dump(mode="json") if isinstance(model, BaseModel) else model
    text = json.dumps(data, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:length]

