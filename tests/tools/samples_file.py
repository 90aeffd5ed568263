"""Sample files for the Python tools' tests, written exactly as host_sim/sim_samples.h specifies
(x, y normalised to [-1, 1] over the box, the header's and the records' CRCs)."""
import struct
import zlib


def write_samples(path, xy_m, occ, box, source=b"scan tools test"):
    """Points xy_m (metres, N x 2) with labels occ into `path`, over the bounding box
    (xmin, ymin, xmax, ymax)."""
    import numpy as np
    xy_m = np.asarray(xy_m, dtype=np.float64)
    xn = 2.0 * (xy_m[:, 0] - box[0]) / (box[2] - box[0]) - 1.0
    yn = 2.0 * (xy_m[:, 1] - box[1]) / (box[3] - box[1]) - 1.0
    recs = np.column_stack([xn, yn, occ]).astype("<f4").tobytes()
    h = bytearray(208)
    h[0:8] = b"FSSAMPLE"
    struct.pack_into("<IIIIQ", h, 8, 1, 208, 12, 0, len(xy_m))
    struct.pack_into("<4d", h, 32, *box)
    struct.pack_into("<Q", h, 64, 7)
    h[72:72 + len(source[:132])] = source[:132]
    struct.pack_into("<I", h, 204, zlib.crc32(bytes(h[:204])))
    with open(path, "wb") as f:
        f.write(bytes(h) + recs + struct.pack("<I", zlib.crc32(recs)))
