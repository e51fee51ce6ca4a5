#pragma once
/// @file VolumeFormats.h
/// The readers of each volume format (internal to io/; readLabelVolume in VolumeReader.h picks
/// one by extension and makes the checks common to all). Each returns the volume with its
/// placement in world space (metres, RAS) and its compact labels; names and colours where the
/// file has them; `placement` saying how the placement was found. Each throws InputError, one
/// line starting with `what` (the path, escaped), as VolumeReader.h states.

#include <string>
#include <string_view>

#include "voxcut/io/VolumeReader.h"

namespace voxcut::volumeio {

/// NIfTI-1 or NIfTI-2 (.nii, .nii.gz), header through nifticlib.
[[nodiscard]] LabelVolume readNifti(const std::string& path, const VolumeReadParams& params);

/// NRRD with attached data (`bytes` is the whole file) or detached data (the data file
/// resolved against `folder`, which must contain it). `what` names the source in messages.
///
/// Read: magics NRRD0001 to NRRD0005; every NRRD spelling of the 8 integer types, float and
/// double; encodings raw and gzip (ascii, hex, bzip2 and block types are refused); 3-D data,
/// and 4-D data whose one non-spatial axis (a 'none' space direction, else a non-domain kind,
/// else a size of 1) is either the first (the layers of a segmentation) or of size 1.
/// Placement: voxel (i,j,k) is centred at `space origin` + sum_a `space directions`_a * index
/// as the format defines it (the origin is the centre of the first sample), whatever `centers`
/// say (they are ignored). Spaces RAS, LPS, LAS (converted to RAS by negating the flipped
/// axes), scanner-xyz, 3D-right-handed and a bare `space dimension: 3` (taken as RAS). Without
/// space directions, `spacings` give an axis-aligned grid (1 mm when absent, with a warning).
/// Lengths are in `space units` (m, cm, mm, um/micron; mm when absent), scaled to metres.
/// Data: raw data must hold exactly the samples after the line and byte skips (byte skip -1:
/// the samples end the data), fewer or more bytes are an InputError; gzip data are inflated
/// with the byte skip applied to the inflated bytes (at most 1 MiB), and anything after the
/// end of the gzip stream is ignored. A detached `data file` must lie inside `folder` (after
/// resolving `..` and links); LIST and numbered data files are refused.
/// Segmentations (3D Slicer .seg.nrrd, SegmentationMetadata.h): segment names and colours
/// label their (layer, value); where layers overlap, the voxel is given the segment with the
/// larger Segment{N} number (values no segment declares rank below every segment); a label's
/// value is its segment's LabelValue when unique in the volume, else one above every value in
/// use; segments with no voxel are dropped, with a warning.
[[nodiscard]] LabelVolume readNrrd(std::string_view bytes, const std::string& folder,
                                   const std::string& what, const VolumeReadParams& params);

/// MetaImage: `bytes` is the whole .mha or .mhd; ElementDataFile LOCAL or a file resolved
/// against `folder`, which must contain it.
///
/// Read: NDims 3 (or 4 with a last size of 1), ElementNumberOfChannels 1, element types
/// MET_CHAR, MET_UCHAR, MET_SHORT, MET_USHORT, MET_INT, MET_UINT, MET_LONG and MET_ULONG
/// (4 bytes, as MetaIO defines them), MET_LONG_LONG, MET_ULONG_LONG, MET_FLOAT, MET_DOUBLE;
/// binary data only, raw or CompressedData (zlib; CompressedDataSize bounds the stream when
/// given). Keys are matched without regard to case.
/// Placement: ITK's physical space, LPS millimetres (DistanceUnits m, cm, um when given):
/// Offset (or Origin, Position) + sum_a TransformMatrix_a * ElementSpacing_a * index_a, where
/// TransformMatrix_a is the a-th run of NDims numbers (the direction of index axis a, as ITK's
/// MetaImageIO reads it); then converted to RAS metres. Without ElementSpacing, ElementSize,
/// else 1 mm with a warning. AnatomicalOrientation is shown in `placement` but not used.
/// Data: LOCAL data start after the ElementDataFile line and must hold exactly the samples
/// (HeaderSize is not used). A detached raw file must hold exactly HeaderSize + the samples
/// bytes (HeaderSize -1: at least the samples, which end the file); a detached compressed
/// file holds the zlib stream after HeaderSize bytes. LIST and numbered data files are refused.
[[nodiscard]] LabelVolume readMetaImage(std::string_view bytes, const std::string& folder,
                                        const std::string& what, const VolumeReadParams& params);

}  // namespace voxcut::volumeio
