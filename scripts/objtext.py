"""What the mesh converters (3ds-to-obj, gltf-to-obj) share: coordinates
printed as the data directory's OBJ files print them."""
import struct
from decimal import Decimal


def f32(x):
    """`x` rounded to the nearest f32."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


def shortest(x):
    """The shortest decimal that reads back as the f32 `x`, positional
    (no exponent), as Rust's `{}` prints an f32."""
    if x == 0:
        return "-0" if struct.pack("<f", x)[3] & 0x80 else "0"
    for digits in range(1, 10):
        text = "%.*e" % (digits - 1, x)
        if f32(float(text)) == x:
            break
    text = format(Decimal(text), "f")
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return text
