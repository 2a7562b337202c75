"""RIHS01 type hashes (REP-2011) for a bag's ``type_description_hash`` fields.

The hash is computed from *our* definition of the type (the text the bag also stores as its schema), so
it matches the standard ROS 2 Jazzy hash exactly when our definition matches the standard one, and
describes our own packages (humanoid_msgs, zenroid_msgs...) faithfully. The computation is rosbags'
(an independent, well-tested implementation); without rosbags installed the field is left empty, which
rosbag2 and rosbags both accept (bags recorded by Humble have no hashes at all).
"""

from __future__ import annotations

import functools

from msgs.schema_text import full_definition


@functools.cache
def rihs01(type_name: str) -> str:
    """``RIHS01_<sha256 hex>`` for a ``pkg/msg/Name`` type, or "" when it cannot be computed here."""
    try:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    except ImportError:
        return ""
    try:
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(full_definition(type_name), type_name))
        return store.hash_rihs01(type_name)
    except Exception:  # noqa: BLE001 - a type rosbags cannot model: no hash rather than no bag
        return ""
