#!/usr/bin/python3
"""World points of voxels of a NIfTI file according to nibabel, for the NIfTI reader's tests.

Usage: nibabel_orientation.py FILE I J K [I J K ...]

Prints one line of JSON: a list whose first element is the image's shape (its dims) and whose
other elements are the points img.affine @ [i, j, k, 1] (x, y, z in the file's units, mm for the
test files), one per voxel given. nibabel's affine is the sform when sform_code is set, else the
qform. Exits with status 3 when nibabel or numpy cannot be imported (the test then skips).
"""
import json
import sys

try:
    import nibabel
    import numpy
except ImportError:
    sys.exit(3)


def main(argv):
    if len(argv) < 2 or (len(argv) - 2) % 3 != 0:
        sys.stderr.write(__doc__)
        return 2
    img = nibabel.load(argv[1])
    affine = numpy.asarray(img.affine, dtype=numpy.float64)
    indices = [int(v) for v in argv[2:]]
    out = [[int(n) for n in img.shape]]
    for at in range(0, len(indices), 3):
        ijk1 = numpy.array(indices[at:at + 3] + [1], dtype=numpy.float64)
        out.append([float(x) for x in (affine @ ijk1)[:3]])
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
