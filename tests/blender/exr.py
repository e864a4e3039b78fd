"""Reading OpenEXR files in tests (no bpy needed): OpenImageIO from pip, since bpy 4.2 bundles no
Python binding of it."""
import numpy as np


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
