"""Files the Blender tests read in the pytest process (no bpy needed): OpenEXR and PNG images
through OpenImageIO from pip (bpy 4.2 bundles no Python binding of it), and the built extension."""
import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]


def extension_zip():
    """The extension zip `make extension` built."""
    zips = sorted((ROOT / "dist").glob("unbound-*.zip"))
    assert zips, "build the extension first: make extension"
    return zips[-1]


def read_png(path):
    """8-bit image -> uint8 (H, W, C), row 0 at the top."""
    import OpenImageIO as oiio
    buf = oiio.ImageBuf(str(path))
    assert not buf.has_error, buf.geterror()
    return buf.get_pixels(oiio.UINT8)


def read_exr(path):
    """{channel name: float32 array (H, W)} of every part of a (possibly multi-part, as 5.x writes)
    OpenEXR file; row 0 is the TOP of the image, as in the file."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    channels, part = {}, 0
    while inp.seek_subimage(part, 0):
        spec = inp.spec()
        data = inp.read_image(part, 0, 0, spec.nchannels, "float")
        for c, name in enumerate(spec.channelnames):
            channels[name] = np.ascontiguousarray(data[..., c])
        part += 1
    inp.close()
    return channels
