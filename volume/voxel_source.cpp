#include "volume/voxel_source.h"

#include <algorithm>
#include <cstdio>
#include <string>

#include <zlib.h>

#include "core/error.h"
#include "volume/readers.h"

namespace isoforge::volume {

namespace {

std::string lowerName(const std::filesystem::path& p) {
    std::string n = p.filename().string();
    for (char& c : n) c = char(std::tolower(static_cast<unsigned char>(c)));
    return n;
}

bool endsWith(const std::string& s, const std::string& e) {
    return s.size() >= e.size() && s.compare(s.size() - e.size(), e.size(), e) == 0;
}

}  // namespace

std::optional<VoxelSource> voxelSource(const std::filesystem::path& path, const VolumeReadOptions& o) {
    std::error_code ec;
    if (!std::filesystem::exists(path, ec)) throw IoError(path.string() + ": no such file or directory");
    if (std::filesystem::is_directory(path, ec)) return detail::dicomSource(path, o.dicomSeries);
    const std::string n = lowerName(path);
    std::optional<VoxelSource> s;
    if (endsWith(n, ".nii") || endsWith(n, ".nii.gz")) s = detail::niftiSource(path);
    if (endsWith(n, ".nrrd") || endsWith(n, ".nhdr")) s = detail::nrrdSource(path);
    if (endsWith(n, ".mha") || endsWith(n, ".mhd")) s = detail::metaImageSource(path);
    if (endsWith(n, ".raw")) s = detail::rawSource(path, o);
    if (!s) return s;
    // Raw parts must be whole in their files; compressed ones show their length only when inflated.
    for (const VoxelSource::Part& p : s->parts) {
        if (p.compressed) continue;
        const std::uint64_t have = std::filesystem::file_size(p.file, ec);
        if (ec || have < p.offset + p.bytes)
            throw IoError(p.file.string() + ": the header promises " + std::to_string(s->header.dims[0]) + " x " +
                          std::to_string(s->header.dims[1]) + " x " + std::to_string(s->header.dims[2]) + " " +
                          s->header.storedType + " voxels (" + std::to_string(p.bytes) + " bytes from offset " +
                          std::to_string(p.offset) + " in this file) but it has " + std::to_string(ec ? 0 : have) +
                          " bytes");
    }
    return s;
}

struct SliceStream::State {
    const VoxelSource& source;
    std::size_t part = 0;        // the part being read
    std::uint64_t left = 0;      // its decoded bytes not yet read
    std::uint64_t produced = 0;  // its decoded bytes read so far (for messages)
    std::FILE* file = nullptr;
    bool open = false;
    z_stream z{};
    bool inflating = false;
    std::vector<unsigned char> in;               // compressed input
    std::vector<unsigned char> bytes;            // stored voxels of one read
    std::uint64_t delivered = 0;                 // voxel bytes handed out, all parts
    std::unique_ptr<detail::DicomSlices> dicom;  // a DICOM series' slices

    explicit State(const VoxelSource& s) : source(s) {}
    ~State() { close(); }

    void close() {
        if (inflating) inflateEnd(&z);
        inflating = false;
        if (file) std::fclose(file);
        file = nullptr;
        open = false;
    }

    const VoxelSource::Part& current() const { return source.parts[part]; }

    [[noreturn]] void ended(const char* how) {
        const VoxelSource::Part& p = current();
        throw IoError(p.file.string() + ": " + how + " after " + std::to_string(produced) + " of the " +
                      std::to_string(p.bytes) + " voxel bytes the header promises (truncated file?)");
    }

    void openPart() {
        const VoxelSource::Part& p = current();
        file = std::fopen(p.file.c_str(), "rb");
        if (!file) throw IoError(p.file.string() + ": cannot open the voxel data");
        if (fseeko(file, off_t(p.offset), SEEK_SET) != 0) throw IoError(p.file.string() + ": cannot seek to its data");
        left = p.bytes;
        produced = 0;
        if (p.compressed) {
            z = z_stream{};
            if (inflateInit2(&z, 15 + 32) != Z_OK) throw IoError(p.file.string() + ": zlib initialisation failed");
            inflating = true;
            in.resize(1 << 20);
            std::vector<unsigned char> sink(64 << 10);
            for (std::uint64_t skip = p.skip; skip > 0;) {  // NRRD's byte skip counts decoded bytes
                const std::size_t n = std::size_t(std::min<std::uint64_t>(skip, sink.size()));
                inflateInto(sink.data(), n, true);
                skip -= n;
            }
        }
        open = true;
    }

    /// Exactly n decoded bytes of the current (compressed) part.
    void inflateInto(unsigned char* out, std::size_t n, bool skipping) {
        z.next_out = out;
        z.avail_out = static_cast<uInt>(n);
        while (z.avail_out > 0) {
            if (z.avail_in == 0) {
                const std::size_t got = std::fread(in.data(), 1, in.size(), file);
                if (got == 0)
                    ended(skipping ? "the compressed data ends in its byte skip" : "the compressed data ends");
                z.next_in = in.data();
                z.avail_in = static_cast<uInt>(got);
            }
            const uInt before = z.avail_out;
            const int rc = inflate(&z, Z_NO_FLUSH);
            if (!skipping) produced += before - z.avail_out;
            if (rc == Z_STREAM_END && z.avail_out > 0) ended("the compressed data ends");
            if (rc != Z_OK && rc != Z_STREAM_END && rc != Z_BUF_ERROR) {
                const VoxelSource::Part& p = current();
                throw IoError(p.file.string() +
                              ": compressed voxel data is corrupt (zlib: " + (z.msg ? z.msg : "error") + ") after " +
                              std::to_string(produced) + " of " + std::to_string(p.bytes) + " bytes");
            }
        }
    }

    void readBytes(unsigned char* out, std::size_t n) {
        while (n > 0) {
            if (!open || left == 0) {
                if (open) {
                    close();
                    ++part;
                }
                if (part >= source.parts.size())
                    throw IoError(source.parts.back().file.string() + ": the voxel data ends early");
                openPart();
                if (left == 0) continue;
            }
            const std::size_t take = std::size_t(std::min<std::uint64_t>(n, left));
            if (current().compressed) {
                inflateInto(out, take, false);
            } else {
                const std::size_t got = std::fread(out, 1, take, file);
                produced += got;
                if (got != take) ended("the data ends");
            }
            left -= take;
            out += take;
            n -= take;
        }
    }
};

SliceStream::SliceStream(const VoxelSource& source) : state_(std::make_unique<State>(source)) {}
SliceStream::~SliceStream() = default;

void SliceStream::read(std::int64_t count, float* out) {
    const DenseVolume& h = state_->source.header;
    if (!state_->source.dicomDirectory.empty()) {
        if (!state_->dicom) state_->dicom = std::make_unique<detail::DicomSlices>(state_->source);
        return state_->dicom->read(count, out);
    }
    const std::size_t voxels = std::size_t(h.dims[0]) * std::size_t(h.dims[1]) * std::size_t(count);
    const std::size_t size = detail::typeSize(h.storedType);
    state_->bytes.resize(voxels * size);
    state_->readBytes(state_->bytes.data(), state_->bytes.size());
    detail::convertVoxels(state_->bytes.data(), h.storedType, state_->source.bigEndian, voxels, out);
    const float slope = state_->source.slope, intercept = state_->source.intercept;
    if (slope != 1.f || intercept != 0.f)
        for (std::size_t i = 0; i < voxels; ++i) out[i] = out[i] * slope + intercept;
}

}  // namespace isoforge::volume
