"""Parse untrusted XML without ever expanding entities or touching the network.

Why: a robot description can arrive over the network (``robot_description`` parameter, spawn requests).
Entity declarations enable "billion laughs" memory bombs and external entities can read local files, so any
document that declares entities, or points at an external DTD, is refused before parsing.
"""

from __future__ import annotations

import re

from lxml import etree

_DOCTYPE = re.compile(rb"<!DOCTYPE", re.IGNORECASE)
_ENTITY_DECL = re.compile(rb"<!ENTITY", re.IGNORECASE)
_EXTERNAL_ID = re.compile(rb"<!DOCTYPE[^>\[]*\b(SYSTEM|PUBLIC)\b", re.IGNORECASE)


class UnsafeXmlError(ValueError):
    """The document declares entities or references an external DTD."""


def check_xml_safety(data: bytes | str) -> None:
    """Raise UnsafeXmlError for entity declarations or external DTDs (checked on the raw text)."""
    raw = data.encode("utf-8") if isinstance(data, str) else data
    if _ENTITY_DECL.search(raw):
        raise UnsafeXmlError("XML declares entities (<!ENTITY ...>): refused, entities are never expanded")
    if _EXTERNAL_ID.search(raw):
        raise UnsafeXmlError("XML references an external DTD (DOCTYPE SYSTEM/PUBLIC): refused")


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False, huge_tree=False,
        remove_comments=True,
    )


def parse_xml(data: bytes | str) -> etree._Element:
    """Parse a document after the safety check; raises UnsafeXmlError or ValueError with the parser's reason."""
    check_xml_safety(data)
    raw = data.encode("utf-8") if isinstance(data, str) else data
    try:
        root = etree.fromstring(raw, parser=_parser())
    except etree.XMLSyntaxError as exc:
        raise ValueError(f"XML syntax error: {exc}") from None
    # Belt and braces: an undeclared entity reference would survive as an _Entity node.
    for node in root.iter():
        if isinstance(node, etree._Entity):
            raise UnsafeXmlError(f"XML contains an entity reference &{node.name};: refused")
    return root
