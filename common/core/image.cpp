#include "common/core/image.h"

#include "common/core/error.h"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStdIO.h>
#include <png.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace alphorn {

namespace {

// Writes the image file through a temporary file beside `path`, renamed over it only once it is
// complete and flushed: a write that fails (a full disk, a file size limit, a lost mount) leaves
// neither a truncated image nor a damaged earlier one at `path`. `write` writes the temporary
// file and throws Error naming `path` on failure. Unlike farm::publishFileAtomically there is no
// fsync: an image can be rendered again, and the rename alone keeps a torn file out of the way.
template <typename Write>
void writeThroughTemporary(const std::string& path, const char* format, Write&& write) {
    const std::string temporary = path + ".partial-" + std::to_string(::getpid());
    try {
        write(temporary);
    } catch (...) {
        std::remove(temporary.c_str());
        throw;
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0) {
        const int error = errno;
        std::remove(temporary.c_str());
        fail("%s: cannot write %s: %s", path, format, std::strerror(error));
    }
}

}  // namespace

namespace {

// The EXR of `image` (float R, G, B; ZIP compression) written to `out`. Throws what OpenEXR
// throws.
void writeEXRTo(Imf::OStream& out, const Image& image) {
    Imf::Header header(image.width, image.height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const char* name : {"R", "G", "B"})
        header.channels().insert(name, Imf::Channel(Imf::FLOAT));
    Imf::FrameBuffer frame;
    const size_t xStride = 3 * sizeof(float), yStride = xStride * image.width;
    char* base = reinterpret_cast<char*>(const_cast<float*>(image.rgb.data()));
    frame.insert("R", Imf::Slice(Imf::FLOAT, base, xStride, yStride));
    frame.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xStride, yStride));
    frame.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xStride, yStride));
    // OpenEXR writes the line offset table when the file object is destroyed and drops an
    // error there; a file stream's state catches it (writeEXR).
    Imf::OutputFile file(out, header);
    file.setFrameBuffer(frame);
    file.writePixels(image.height);
}

}  // namespace

void writeEXR(const std::string& path, const Image& image) {
    writeThroughTemporary(path, "EXR", [&](const std::string& temporary) {
        std::ofstream stream(temporary, std::ios::binary | std::ios::trunc);
        if (!stream) fail("%s: cannot write EXR: %s", path, std::strerror(errno));
        try {
            Imf::StdOFStream imfStream(stream, path.c_str());
            writeEXRTo(imfStream, image);
        } catch (const std::exception& e) {
            fail("%s: cannot write EXR: %s", path, e.what());
        }
        stream.close();
        if (stream.fail()) fail("%s: cannot write EXR: the file could not be written whole", path);
    });
}

std::string encodeEXR(const Image& image) {
    try {
        Imf::StdOSStream stream;
        writeEXRTo(stream, image);
        return stream.str();
    } catch (const std::exception& e) {
        fail("cannot encode EXR: %s", e.what());
    }
}

void checkDeclaredImageSize(const std::string& path, uint64_t width, uint64_t height,
                            uint64_t rawBytes, uint64_t fileBytes) {
    if (width * height > kMaxImageFilePixels)
        throw ResourceLimitError(absl::StrFormat(
            "%s: the image is %ux%u pixels, more than the %u (16384 x 16384) allowed", path, width,
            height, kMaxImageFilePixels));
    if (rawBytes > 1100 * fileBytes)
        fail(
            "%s: the header declares a %ux%u image (%u bytes of pixels) in a file of %u bytes, "
            "more than its compression can hold: the file is truncated or not a real image",
            path, width, height, rawBytes, fileBytes);
}

Image readEXR(const std::string& path) {
    std::error_code sizeError;
    const uint64_t fileBytes = std::filesystem::file_size(path, sizeError);
    try {
        Imf::InputFile file(path.c_str());
        Imath::Box2i window = file.header().dataWindow();
        // As 64-bit integers: a crafted window's corners can be anywhere in int's range.
        const int64_t windowWidth = int64_t(window.max.x) - window.min.x + 1;
        const int64_t windowHeight = int64_t(window.max.y) - window.min.y + 1;
        if (windowWidth <= 0 || windowHeight <= 0) fail("%s: the EXR's data window is empty", path);
        // At least one channel of 16-bit halves per pixel.
        checkDeclaredImageSize(path, uint64_t(windowWidth), uint64_t(windowHeight),
                               2 * uint64_t(windowWidth) * uint64_t(windowHeight),
                               sizeError ? 0 : fileBytes);
        const int width = int(windowWidth), height = int(windowHeight);
        Image image(width, height);
        const size_t xStride = 3 * sizeof(float), yStride = xStride * width;
        char* base = reinterpret_cast<char*>(image.rgb.data()) -
                     (window.min.x * xStride + window.min.y * yStride);
        Imf::FrameBuffer frame;
        frame.insert("R", Imf::Slice(Imf::FLOAT, base, xStride, yStride, 1, 1, 0.0));
        frame.insert("G",
                     Imf::Slice(Imf::FLOAT, base + sizeof(float), xStride, yStride, 1, 1, 0.0));
        frame.insert("B",
                     Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xStride, yStride, 1, 1, 0.0));
        file.setFrameBuffer(frame);
        file.readPixels(window.min.y, window.max.y);
        return image;
    } catch (const Error&) {
        throw;
    } catch (const std::exception& e) {
        fail("%s: cannot read EXR: %s", path, e.what());
    }
}

namespace {

// Reads one whitespace-delimited header token of at most `limit` characters; empty at the end of
// the file or when the token is longer (no real PFM header field is).
std::string pfmToken(std::istream& in, size_t limit) {
    std::string token;
    int c = in.get();
    while (c != EOF && std::isspace(c)) c = in.get();
    while (c != EOF && !std::isspace(c)) {
        if (token.size() == limit) return {};
        token.push_back(char(c));
        c = in.get();
    }
    // The single whitespace character after the last field, the scale, ends the header.
    return token;
}

bool parseDimension(const std::string& text, uint64_t& value) {
    if (text.empty() || text.size() > 9) return false;
    value = 0;
    for (char c : text) {
        if (c < '0' || c > '9') return false;
        value = value * 10 + uint64_t(c - '0');
    }
    return value > 0;
}

bool hostIsLittleEndian() {
    const uint32_t one = 1;
    unsigned char first;
    std::memcpy(&first, &one, 1);
    return first == 1;
}

}  // namespace

Image readPFM(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) fail("%s: cannot open the PFM file", path);
    const std::string magic = pfmToken(in, 2);
    if (magic != "PF" && magic != "Pf")
        fail("%s: not a PFM file (it must start with \"PF\" or \"Pf\")", path);
    const int channels = magic == "PF" ? 3 : 1;
    uint64_t width = 0, height = 0;
    if (!parseDimension(pfmToken(in, 16), width) || !parseDimension(pfmToken(in, 16), height))
        fail("%s: the PFM header has no valid positive width and height", path);
    const std::string scaleText = pfmToken(in, 64);
    char* end = nullptr;
    const double scale = scaleText.empty() ? 0.0 : std::strtod(scaleText.c_str(), &end);
    if (scaleText.empty() || *end != '\0' || !(scale != 0.0) || !std::isfinite(scale))
        fail("%s: the PFM header's scale (byte order) must be a non-zero number", path);
    const bool littleEndian = scale < 0.0;
    const uint64_t rawBytes = width * height * channels * sizeof(float);
    std::error_code sizeError;
    const uint64_t fileBytes = std::filesystem::file_size(path, sizeError);
    checkDeclaredImageSize(path, width, height, rawBytes, sizeError ? 0 : fileBytes);
    const std::streamoff headerBytes = in.tellg();
    if (sizeError || headerBytes < 0 || fileBytes - uint64_t(headerBytes) != rawBytes)
        fail(
            "%s: the PFM header declares %ux%u pixels (%u bytes) but the file holds %d bytes "
            "after its header",
            path, width, height, rawBytes,
            sizeError || headerBytes < 0 ? int64_t(-1) : int64_t(fileBytes - headerBytes));
    std::vector<float> values(width * height * channels);
    if (!in.read(reinterpret_cast<char*>(values.data()), std::streamsize(rawBytes)))
        fail("%s: cannot read the PFM's pixels", path);
    if (littleEndian != hostIsLittleEndian())
        for (float& v : values) {
            uint32_t bits;
            std::memcpy(&bits, &v, 4);
            bits = __builtin_bswap32(bits);
            std::memcpy(&v, &bits, 4);
        }
    Image image(static_cast<int>(width), static_cast<int>(height));
    for (uint64_t row = 0; row < height; ++row)
        for (uint64_t x = 0; x < width; ++x) {
            const float* p = &values[((height - 1 - row) * width + x) * channels];
            image.set(int(x), int(row), channels == 3 ? Color3f(p[0], p[1], p[2]) : Color3f(p[0]));
        }
    return image;
}

void writePFM(const std::string& path, const Image& image) {
    writeThroughTemporary(path, "PFM", [&](const std::string& temporary) {
        std::ofstream out(temporary, std::ios::binary);
        out << "PF\n"
            << image.width << " " << image.height << "\n"
            << (hostIsLittleEndian() ? "-1" : "1") << "\n";
        for (int row = image.height - 1; row >= 0; --row)
            out.write(reinterpret_cast<const char*>(&image.rgb[3 * size_t(row) * image.width]),
                      std::streamsize(3 * sizeof(float) * image.width));
        out.flush();
        if (!out) fail("%s: cannot write the PFM file", path);
    });
}

namespace {
struct FileCloser {
    void operator()(FILE* f) const {
        if (f) std::fclose(f);
    }
};
using FilePtr = std::unique_ptr<FILE, FileCloser>;

[[noreturn]] void pngError(png_structp png, png_const_charp message) {
    auto* text = static_cast<std::string*>(png_get_error_ptr(png));
    *text = message;
    png_longjmp(png, 1);
}
void pngWarning(png_structp, png_const_charp) {}
}  // namespace

namespace {

// Writes the 8-bit sRGB PNG of image * 2^exposure through `png`, whose output `setOutput(png)`
// chooses; `what` names the destination in errors.
template <typename SetOutput>
void writePNGWith(const std::string& what, const Image& image, float exposure,
                  SetOutput&& setOutput) {
    const float scale = std::exp2(exposure);
    std::vector<uint8_t> pixels(3 * size_t(image.width) * image.height);
    for (size_t i = 0; i < pixels.size(); ++i) {
        float v = image.rgb[i] * scale;
        v = std::isfinite(v) ? clamp(v, 0.0f, 1.0f) : 0.0f;
        Color3f encoded = Color3f(v).toSRGB();
        pixels[i] = static_cast<uint8_t>(std::lround(encoded.r() * 255.0f));
    }
    std::string error;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &error, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_write_struct(&png, nullptr);
        fail("%s: cannot write PNG: out of memory", what);
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fail("%s: cannot write PNG: %s", what, error);
    }
    setOutput(png);
    png_set_IHDR(png, info, image.width, image.height, 8, PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
    png_write_info(png, info);
    for (int y = 0; y < image.height; ++y) png_write_row(png, &pixels[3 * size_t(y) * image.width]);
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
}

// No exception may cross libpng's C frames: running out of memory is reported the libpng way.
void appendToString(png_structp png, png_bytep data, png_size_t length) {
    try {
        static_cast<std::string*>(png_get_io_ptr(png))
            ->append(reinterpret_cast<char*>(data), length);
    } catch (const std::bad_alloc&) {
        png_error(png, "out of memory");
    }
}
void flushNothing(png_structp) {}

}  // namespace

void writePNG(const std::string& path, const Image& image, float exposure) {
    writeThroughTemporary(path, "PNG", [&](const std::string& temporary) {
        FilePtr file(std::fopen(temporary.c_str(), "wb"));
        if (!file) fail("%s: cannot write PNG: %s", path, std::strerror(errno));
        writePNGWith(path, image, exposure, [&](png_structp png) { png_init_io(png, file.get()); });
        // Buffered bytes reach the file only here: a full disk shows up as a failed flush or close.
        int closeError = 0;
        if (std::fflush(file.get()) != 0 || std::ferror(file.get()))
            closeError = errno ? errno : EIO;
        if (std::fclose(file.release()) != 0 && closeError == 0) closeError = errno ? errno : EIO;
        if (closeError != 0) fail("%s: cannot write PNG: %s", path, std::strerror(closeError));
    });
}

std::string encodePNG(const Image& image, float exposure) {
    std::string bytes;
    writePNGWith("PNG in memory", image, exposure, [&](png_structp png) {
        png_set_write_fn(png, &bytes, appendToString, flushNothing);
    });
    return bytes;
}

Image readPNG(const std::string& path) {
    FilePtr file(std::fopen(path.c_str(), "rb"));
    if (!file) fail("%s: cannot read PNG: %s", path, std::strerror(errno));
    std::string error;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &error, pngError, pngWarning);
    png_infop info = png ? png_create_info_struct(png) : nullptr;
    if (!png || !info) {
        png_destroy_read_struct(&png, nullptr, nullptr);
        fail("%s: cannot read PNG: out of memory", path);
    }
    Image image;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        fail("%s: cannot read PNG: %s", path, error);
    }
    png_init_io(png, file.get());
    png_read_info(png, info);
    std::error_code sizeError;
    const uint64_t fileBytes = std::filesystem::file_size(path, sizeError);
    try {
        checkDeclaredImageSize(
            path, png_get_image_width(png, info), png_get_image_height(png, info),
            uint64_t(png_get_rowbytes(png, info)) * png_get_image_height(png, info),
            sizeError ? 0 : fileBytes);
    } catch (const Error&) {
        png_destroy_read_struct(&png, &info, nullptr);
        throw;
    }
    // Normalise every PNG flavour to 8-bit RGB.
    png_set_strip_16(png);
    png_set_strip_alpha(png);
    png_set_palette_to_rgb(png);
    png_set_expand_gray_1_2_4_to_8(png);
    png_set_gray_to_rgb(png);
    png_read_update_info(png, info);
    const int width = static_cast<int>(png_get_image_width(png, info));
    const int height = static_cast<int>(png_get_image_height(png, info));
    std::vector<uint8_t> row(png_get_rowbytes(png, info));
    image = Image(width, height);
    for (int y = 0; y < height; ++y) {
        png_read_row(png, row.data(), nullptr);
        for (int x = 0; x < width; ++x)
            image.set(x, y,
                      Color3f(row[3 * x] / 255.0f, row[3 * x + 1] / 255.0f, row[3 * x + 2] / 255.0f)
                          .toLinearRGB());
    }
    png_destroy_read_struct(&png, &info, nullptr);
    return image;
}

std::string pngPathFor(const std::string& exrPath) {
    return std::filesystem::path(exrPath).replace_extension(".png").string();
}

}  // namespace alphorn
