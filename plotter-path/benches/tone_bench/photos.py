"""Write the tone bench's photos as gray PNGs (sRGB-encoded luminance, computed in linear light).

Usage: photos.py OUT_DIR [MATE_BACKGROUNDS_DIR]

Sources and licences:
- astronaut (portrait): scikit-image data, NASA photograph of Eileen Collins, public domain.
- camera (portrait): scikit-image data, CC0 by Lav Varshney.
- chelsea (animal, a cat): scikit-image data, CC0 by Stefan van der Walt.
- coffee (still life): scikit-image data, CC0 by Rachel Michetti.
- storm (landscape): Debian package mate-backgrounds, nature/Storm.jpg, (c) 2008 Sergey Nazarov, GPL-2+.
"""

import sys
from pathlib import Path

import numpy as np
from PIL import Image
from skimage import data


def srgb_to_linear(v):
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v):
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * v ** (1 / 2.4) - 0.055)


def gray(rgb):
    """Luminance in linear light (Rec. 709 weights), encoded back to sRGB 8-bit."""
    a = np.asarray(rgb, dtype=np.float64) / 255.0
    if a.ndim == 2:
        return np.asarray(rgb, dtype=np.uint8)
    lin = srgb_to_linear(a[..., :3])
    y = lin @ np.array([0.2126, 0.7152, 0.0722])
    return np.clip(np.round(linear_to_srgb(y) * 255.0), 0, 255).astype(np.uint8)


def main():
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    photos = {
        "astronaut": data.astronaut(),
        "camera": data.camera(),
        "chelsea": data.chelsea(),
        "coffee": data.coffee(),
    }
    if len(sys.argv) > 2:
        storm = Path(sys.argv[2]) / "nature" / "Storm.jpg"
        if storm.exists():
            img = Image.open(storm).convert("RGB")
            img = img.resize((720, 480), Image.LANCZOS)
            photos["storm"] = np.asarray(img)
        else:
            print(f"photos: {storm} not found, the landscape is left out", file=sys.stderr)
    for name, rgb in photos.items():
        Image.fromarray(gray(rgb), mode="L").save(out / f"{name}.png")
        print(name)


if __name__ == "__main__":
    main()
