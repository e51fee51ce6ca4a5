#pragma once
/// @file VolumeWriter.h
/// Writes a label volume as a NRRD file that readLabelVolume (io/VolumeReader.h) reads back
/// exactly: what an application saves its own segmentation as, so that a scene can name it
/// (docs/scenes.md, "Writing scenes").
///
/// Thread-safety: reentrant; distinct paths may be written concurrently.

#include <string>

#include "voxcut/voxel/LabelVolume.h"

namespace voxcut {

/// Writes `volume` to `path` as a NRRD file with attached data (NRRD0004, 3-D, raw encoding,
/// little endian): per voxel its label value (0 for background, else labels[index - 1].value)
/// in the volume's voxel order, as the smallest integer type that holds every label value and
/// 0 (unsigned where none is negative: uint8, uint16, uint32, uint64; else int8 ... int64);
/// `space: right-anterior-superior` with `space units: "m" "m" "m"`, `space directions` the
/// columns of volume.axes and `space origin` volume.origin, each number in the shortest form
/// that reads back to the same double. Names and colours of labels are not written.
///
/// readLabelVolume(path) then gives the same dims, axes and origin bit for bit and the same
/// label value in every voxel; its labels are the values present, ascending (those of a
/// volume readLabelVolume gave), without names. A volume with no labelled voxel is written,
/// and refused by readLabelVolume.
///
/// The file is written as `path + ".tmp"` and renamed to `path` when complete, so an
/// interrupted write never leaves a partial file at `path`; on failure the temporary is
/// removed. Throws InputError naming `path` for a placement readLabelVolume would refuse
/// (checkLabelVolumePlacement), an index that does not match dims or names no label, and a
/// file that cannot be created, written or renamed. Time linear in the voxels; memory one
/// slice.
void writeNrrd(const LabelVolume& volume, const std::string& path);

}  // namespace voxcut
