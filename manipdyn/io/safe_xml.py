"""The hardened XML parse and the checked number readers that the robot readers share (URDF: io/urdf.py and
io/urdf_closures.py; MJCF: io/mjcf_read.py; io/load.py and viz/geometry.py parse with it too).

- ``parse_xml``: well-formed XML with the expected root element. DTDs and entities are refused (no expansion,
  no network access), comments are dropped, lxml's limits on huge documents stay on. Two things libxml2 refuses
  but urdfdom, MuJoCo and PyBullet read are repaired, each with a quirk (quirks.QUIRK_KINDS): whitespace before
  the XML declaration and NUL bytes after the document are removed ("xml_text"), and a declared version that
  is not 1.x is read as XML 1.0 ("xml_version"). The size limit is checked by the callers, before parsing:
  ``MAX_BYTES`` is its default.
- The number grammar, ``NUMBER``: plain decimal (an optional sign, digits with an optional fraction or a
  fraction alone, an optional exponent; ASCII digits only). ``LIST`` is numbers separated by XML white space
  (``SPACE``).
- ``MAX_MASS``, ``MAX_INERTIA``, ``MAX_LENGTH``: the bounds on what a robot file may say, so that every
  computation of the model stays finite.
- ``numbers`` (an attribute read as a given count of numbers in the grammar, finite), ``bounded`` (numbers
  checked against a bound) and ``show`` (an attribute value cut short for a message). ``numbers`` and
  ``bounded`` raise URDFError naming the element, the attribute and its value; the MJCF reader has its own
  readers with the same grammar, raising MJCFError.
"""
from __future__ import annotations

import io
import math
import re

from lxml import etree

from ..errors import URDFError
from ..quirks import Quirk

__all__ = ["parse_xml", "NUMBER", "SPACE", "LIST", "MAX_BYTES", "MAX_MASS", "MAX_INERTIA", "MAX_LENGTH", "numbers",
           "bounded", "show"]

# The number grammar: optional sign, digits with an optional fraction (or a fraction alone), an optional
# exponent; ASCII digits only. Items of a vector are separated by XML white space.
NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
SPACE = re.compile(r"[ \t\n\r]+")
LIST = re.compile(r"[ \t\n\r]*(?:{0}(?:[ \t\n\r]+{0})*)?[ \t\n\r]*".format(NUMBER.pattern))

# Bounds that keep a model's computations finite. The heaviest machines built weigh ~1e9 kg and span
# ~1e3 m; the bounds leave three orders of magnitude beyond that. With 1e5 bodies, the largest force
# (m g) ~1e17 N, moment (m g L n) ~1e28 N m, mass-matrix entry (I + m L²) n ~1e29: products and squares
# of these (energies, norms, condition numbers) stay far below the float range (1e308).
MAX_MASS = 1e12        # kg, per link
MAX_INERTIA = 1e12     # kg m², per entry of a link's inertia
MAX_LENGTH = 1e6       # m, per coordinate of an origin (joint, inertial, constraint) and prismatic limits
MAX_BYTES = 50_000_000  # default size limit of a robot file (URDF, MJCF); example-robot-data's largest is 0.21 MB

# A leading XML declaration's version pseudo-attribute (after an optional UTF-8 byte-order mark), its value in
# XML 1.0's (4th edition) VersionNum grammar. libxml2 refuses a version that is not 1.x ("Unsupported version
# '0.0'"); urdfdom's tinyxml2 (Pinocchio 4.1: checked), MuJoCo, PyBullet and Drake ignore it.
_DECLARED_VERSION = re.compile(rb"(?:\xef\xbb\xbf)?<\?xml[ \t\r\n]+version[ \t\r\n]*=[ \t\r\n]*"
                               rb"(['\"])([A-Za-z0-9_.:-]+)\1")
_XML_1 = re.compile(rb"1\.[0-9]+")           # the versions libxml2 reads (XML 1.0 5th edition's VersionNum)


def parse_xml(data: bytes, source: str, quirks=None, root_tag="robot", error=URDFError):
    """Well-formed XML with a <robot> root (``root_tag``; None: any root); DTDs and entities are refused (no
    expansion, no network). Errors are ``error`` (URDFError; the MJCF reader passes MJCFError).

    A leading XML declaration whose version is not 1.x is read as XML 1.0 (only its version value is replaced,
    before parsing), with an "xml_version" quirk appended to ``quirks``; any other malformed declaration stays
    malformed XML."""
    if b"<!ENTITY" in data:                   # before parsing: nothing is expanded or fetched
        raise error(f"{source}: DOCTYPE/ENTITY declarations are refused (entity expansion)")
    lead = len(data) - len(data.lstrip(b" \t\r\n"))         # before a declaration: libxml2 refuses it
    spaced, nul = lead > 0 and data[lead:].startswith(b"<?xml"), data.rstrip(b" \t\r\n").endswith(b"\0")
    if spaced or nul:
        what = ["whitespace before the XML declaration"] * spaced + ["NUL bytes after the document"] * nul
        if quirks is not None:
            quirks.append(Quirk("xml_text", "<?xml?>", f"{' and '.join(what)}: removed (libxml2 refuses them; "
                                f"urdfdom, MuJoCo and PyBullet read the file)"))
        data = data[lead if spaced else 0:].rstrip(b"\0 \t\r\n") if nul else data[lead:]
    m = _DECLARED_VERSION.match(data)
    if m and not _XML_1.fullmatch(m.group(2)):
        version = m.group(2).decode("ascii")
        data = data[:m.start(2)] + b"1.0" + data[m.end(2):]
        if quirks is not None:
            quirks.append(Quirk("xml_version", "<?xml?>", f"<?xml version={show(version)}?>: not XML 1.x; read as "
                                f"XML 1.0 (urdfdom, MuJoCo, PyBullet and Drake ignore the version)"))
    parser = etree.XMLParser(resolve_entities=False, no_network=True, load_dtd=False, huge_tree=False,
                             remove_comments=True)
    try:
        root = etree.parse(io.BytesIO(data), parser).getroot()
    except etree.XMLSyntaxError as exc:
        raise error(f"{source}: malformed XML: {exc}") from None
    if root is None:
        raise error(f"{source}: malformed XML: no root element")
    if root.getroottree().docinfo.internalDTD is not None:
        raise error(f"{source}: DOCTYPE/ENTITY declarations are refused (entity expansion)")
    if root_tag is not None and root.tag != root_tag:
        raise error(f"{source}: root element is <{root.tag}>, expected <{root_tag}>")
    return root


def show(text, limit=60):
    """An attribute value for a message: repr, cut to ``limit`` characters."""
    return repr(text if len(text) <= limit else text[:limit] + "...")


def numbers(e, key, count, where, source):
    """The ``count`` numbers of attribute ``key`` of element ``e`` (None if absent): URDF grammar, finite.

    Returns a list of floats. Raises URDFError naming ``where`` (the link/joint), the element, the
    attribute and its value.
    """
    text = e.get(key)
    if text is None:
        return None
    at = lambda: f"{source}: {where}: <{e.tag} {key}={show(text)}>"  # noqa: E731
    if not LIST.fullmatch(text):              # the slow path only to name the offending item
        bad = next(t for t in SPACE.split(text) if t and not NUMBER.fullmatch(t))
        raise URDFError(f"{at()}: {show(bad, 30)} is not a URDF number (plain decimal: sign, digits, "
                        f"fraction, exponent; no nan, inf, hex, '_' or non-ASCII digits)")
    x = [float(t) for t in text.split()]      # only ASCII white space is left: split() is the grammar's
    if len(x) != count:
        raise URDFError(f"{at()}: {len(x)} number(s), expected {count}")
    if not all(map(math.isfinite, x)):
        raise URDFError(f"{at()}: overflows the float range")
    return x


def bounded(x, bound, what, e, key, where, source):
    """x (list of floats, or None) with every |x_k| <= bound; URDFError naming the attribute otherwise."""
    for v in x or ():
        if abs(v) > bound:
            raise URDFError(f"{source}: {where}: <{e.tag} {key}={show(e.get(key))}>: {what} {v:g} "
                            f"beyond the bound {bound:g}")
    return x
