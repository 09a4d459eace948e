#pragma once
/// @file Medical-style views of dense volumes: slices with window/level and colour maps, maximum
/// intensity projections, emission-absorption volume rendering with transfer functions, and label
/// voxels drawn as cubes by exact ray-voxel traversal.
///
/// Slices and projections are shown the way radiologists read them: axial seen from the feet (the
/// patient's left on the image's right, anterior up), coronal seen from the front (left on the right,
/// superior up), sagittal seen from the patient's left (anterior on the left, superior up). The index
/// axis closest to the anatomical one is used (no resampling of oblique volumes), and pixels are made
/// square by bilinear resampling of the in-plane axes.

#include <array>
#include <string>
#include <vector>

#include "render/image.h"
#include "render/scene.h"
#include "volume/dense_volume.h"
#include "volume/labels.h"

namespace isoforge::render {

enum class Anatomical { Axial, Coronal, Sagittal };
/// "axial", "coronal", "sagittal". @throw std::invalid_argument otherwise.
Anatomical parseAnatomical(const std::string& name);

struct WindowLevel {
    float window = 0.f, level = 0.f;  ///< window 0: the volume's full range
};

/// Colour maps for intensities: "grey", "hot", "bone", "viridis"; or "labels" with a label table.
struct SliceLook {
    WindowLevel wl;
    std::string colormap = "grey";
    const volume::LabelTable* labels = nullptr;  ///< for "labels": colours by integer value
};

/// The index axis used for an anatomical direction and the in-plane axes with their flips.
struct ViewAxes {
    int slice = 2;            ///< index axis across the view
    int right = 0, down = 1;  ///< index axes along the image's x (right) and y (down)
    bool flipRight = false, flipDown = false;
};
ViewAxes viewAxes(const volume::DenseVolume& v, Anatomical view);

/// One slice at `index` along the view's slice axis. @throw std::out_of_range naming the valid range.
Image sliceVolume(const volume::DenseVolume& v, Anatomical view, std::int64_t index, const SliceLook& look);

/// Maximum intensity projection along the view's slice axis.
Image maximumIntensityProjection(const volume::DenseVolume& v, Anatomical view, const SliceLook& look);

/// A transfer function: control points (value, sRGB colour, opacity per millimetre of ray), linear
/// in between, clamped outside.
struct TransferFunction {
    struct Point {
        float value;
        std::array<float, 3> color;
        float opacity;
    };
    std::vector<Point> points;
    void sample(float value, std::array<float, 3>& color, float& opacity) const;
};
/// "ct-bone", "ct-soft", "mr" (MR scales to the volume's range). @throw std::invalid_argument.
TransferFunction transferPreset(const std::string& name, float lo, float hi);
/// "V:R,G,B,A V:R,G,B,A ..." (colour 0-1, A opacity per mm). @throw std::invalid_argument with the position.
TransferFunction parseTransferFunction(const std::string& text);

/// Emission-absorption ray marching (front to back, half-voxel steps, trilinear samples, early
/// termination, gradient shading from a headlight). Deterministic; parallel over tiles.
Frame renderVolume(const volume::DenseVolume& v, const TransferFunction& tf, const Look& look,
                   const RenderOptions& options, RenderStats* stats = nullptr);

/// Label voxels as cubes: rays walk the voxel grid exactly (Amanatides and Woo), the first non-zero
/// voxel is hit on the face the ray crossed; faces shaded by their normal, with darkened edges.
Frame renderVoxels(const volume::DenseVolume& v, const volume::LabelTable& labels, const Look& look,
                   const RenderOptions& options, RenderStats* stats = nullptr);

/// World-space bounds of the volume (its eight corner voxel centres, padded by half a voxel).
implicit::Box3 volumeBounds(const volume::DenseVolume& v);

}  // namespace isoforge::render
