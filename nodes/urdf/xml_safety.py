"""Parse untrusted XML without ever expanding entities or touching the network.

Why: a robot description can arrive over the network (``robot_description`` parameter, spawn requests).
Entity declarations enable "billion laughs" memory bombs and external entities can read local files, so any
document that declares entities, or points at an external DTD, is refused before parsing.
"""

from __future__ import annotations

import codecs
import re

from lxml import etree

_ENTITY_DECL = re.compile(r"<!ENTITY", re.IGNORECASE)
_EXTERNAL_ID = re.compile(r"<!DOCTYPE[^>\[]*\b(SYSTEM|PUBLIC)\b", re.IGNORECASE)
_XML_DECLARATION = re.compile(r"^\s*<\?xml[^>]*\?>")
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"), (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF16_LE, "utf-16"), (codecs.BOM_UTF16_BE, "utf-16"), (codecs.BOM_UTF8, "utf-8-sig"),
)


class UnsafeXmlError(ValueError):
    """The document declares entities or references an external DTD."""


class XmlSyntaxError(ValueError):
    """The document is not well-formed XML; ``line`` is where the parser stopped (None when unknown)."""

    def __init__(self, message: str, line: int | None = None) -> None:
        super().__init__(message)
        self.line = line


def xml_text(data: bytes | str) -> str:
    """The document as text. Why decode ourselves: a check on raw bytes misses a UTF-16 document."""
    if isinstance(data, str):
        text = data
    else:
        for bom, encoding in _BOMS:
            if data.startswith(bom):
                text = data.decode(encoding)
                break
        else:
            try:
                text = data.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise ValueError(f"XML is not UTF-8 (nor UTF-16/32 with a byte order mark): {exc}") from None
    if "\x00" in text:
        raise ValueError("XML contains NUL characters (UTF-16 without a byte order mark?)")
    return text


def check_xml_safety(data: bytes | str) -> None:
    """Raise UnsafeXmlError for entity declarations or external DTDs (checked on the decoded text)."""
    text = xml_text(data)
    if _ENTITY_DECL.search(text):
        raise UnsafeXmlError("XML declares entities (<!ENTITY ...>): refused, entities are never expanded")
    if _EXTERNAL_ID.search(text):
        raise UnsafeXmlError("XML references an external DTD (DOCTYPE SYSTEM/PUBLIC): refused")


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False, no_network=True, load_dtd=False, dtd_validation=False, huge_tree=False,
        remove_comments=True,
    )


def parse_xml(data: bytes | str) -> etree._Element:
    """Parse a document after the safety check; raises UnsafeXmlError or ValueError with the parser's reason."""
    text = xml_text(data)
    check_xml_safety(text)
    # Parse the checked text, as UTF-8 whatever the declaration said (it was decoded above).
    raw = _XML_DECLARATION.sub("", text, count=1).encode("utf-8")
    try:
        root = etree.fromstring(raw, parser=_parser())
    except etree.XMLSyntaxError as exc:
        raise XmlSyntaxError(f"XML syntax error: {exc}", exc.lineno) from None
    # Belt and braces: an undeclared entity reference would survive as an _Entity node.
    for node in root.iter():
        if isinstance(node, etree._Entity):
            raise UnsafeXmlError(f"XML contains an entity reference &{node.name};: refused")
    return root
