#include "common/scene/ply_reader.h"

#include "common/core/error.h"

#include <absl/strings/str_format.h>

#include <zlib.h>

#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <vector>

namespace alphorn {

namespace {

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<PlyType> typeNamed(std::string_view name) {
    if (name == "char" || name == "int8") return PlyType::Int8;
    if (name == "uchar" || name == "uint8") return PlyType::UInt8;
    if (name == "short" || name == "int16") return PlyType::Int16;
    if (name == "ushort" || name == "uint16") return PlyType::UInt16;
    if (name == "int" || name == "int32") return PlyType::Int32;
    if (name == "uint" || name == "uint32") return PlyType::UInt32;
    if (name == "float" || name == "float32") return PlyType::Float32;
    if (name == "double" || name == "float64") return PlyType::Float64;
    return std::nullopt;
}

size_t sizeOf(PlyType type) {
    switch (type) {
        case PlyType::Int8:
        case PlyType::UInt8:
            return 1;
        case PlyType::Int16:
        case PlyType::UInt16:
            return 2;
        case PlyType::Int32:
        case PlyType::UInt32:
        case PlyType::Float32:
            return 4;
        case PlyType::Float64:
            return 8;
    }
    return 0;
}

bool isInteger(PlyType type) {
    return type != PlyType::Float32 && type != PlyType::Float64;
}

// The range of an integer type (every one fits a double exactly).
void integerRange(PlyType type, double& lo, double& hi) {
    switch (type) {
        case PlyType::Int8:
            lo = -128, hi = 127;
            return;
        case PlyType::UInt8:
            lo = 0, hi = 255;
            return;
        case PlyType::Int16:
            lo = -32768, hi = 32767;
            return;
        case PlyType::UInt16:
            lo = 0, hi = 65535;
            return;
        case PlyType::Int32:
            lo = -2147483648.0, hi = 2147483647.0;
            return;
        default:
            lo = 0, hi = 4294967295.0;
    }
}

struct PlyProperty {
    std::string name;
    bool isList = false;
    PlyType countType = PlyType::UInt8;  // lists only
    PlyType type = PlyType::Float32;     // the value's, or a list item's
};

struct PlyElement {
    std::string name;
    uint64_t count = 0;
    std::vector<PlyProperty> properties;
};

enum class PlyFormat { Ascii, LittleEndian, BigEndian };

struct PlyHeader {
    PlyFormat format = PlyFormat::Ascii;
    std::vector<PlyElement> elements;
    size_t dataOffset = 0;  // where the first element's data starts
    size_t lines = 0;       // the header's lines (an ASCII file's data starts on the next)
};

std::vector<std::string_view> splitWords(std::string_view line) {
    std::vector<std::string_view> words;
    size_t i = 0;
    while (i < line.size()) {
        while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
        const size_t start = i;
        while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
        if (i > start) words.push_back(line.substr(start, i - start));
    }
    return words;
}

PlyHeader parseHeader(std::string_view bytes, const std::string& name) {
    PlyHeader header;
    size_t position = 0;
    bool sawFormat = false;
    // A header line, without its "\n" or "\r\n"; false at the end of the bytes.
    auto nextLine = [&](std::string_view& line) {
        if (position >= bytes.size()) return false;
        size_t end = bytes.find('\n', position);
        if (end == std::string_view::npos) end = bytes.size();
        line = bytes.substr(position, end - position);
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        position = end + 1;
        ++header.lines;
        return true;
    };
    std::string_view line;
    if (!nextLine(line) || line != "ply")
        fail("%s: not a PLY file (it does not start with a \"ply\" line)", name);
    while (true) {
        if (!nextLine(line)) fail("%s: the PLY header has no \"end_header\" line", name);
        const std::vector<std::string_view> words = splitWords(line);
        auto problem = [&](const std::string& what) {
            fail("%s:%d: %s in the PLY header: \"%s\"", name, header.lines, what,
                 std::string(line.substr(0, 80)));
        };
        if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
        if (words[0] == "end_header") {
            if (words.size() != 1) problem("text after end_header");
            break;
        }
        if (words[0] == "format") {
            if (sawFormat) problem("a second format line");
            if (words.size() != 3) problem("a format line needs a format and a version");
            if (words[1] == "ascii")
                header.format = PlyFormat::Ascii;
            else if (words[1] == "binary_little_endian")
                header.format = PlyFormat::LittleEndian;
            else if (words[1] == "binary_big_endian")
                header.format = PlyFormat::BigEndian;
            else
                problem("an unknown format (ascii, binary_little_endian, binary_big_endian)");
            if (words[2] != "1.0") problem("an unsupported version (only 1.0)");
            sawFormat = true;
        } else if (words[0] == "element") {
            if (words.size() != 3) problem("an element line needs a name and a count");
            PlyElement element;
            element.name = std::string(words[1]);
            const std::string_view count = words[2];
            const auto [end, error] =
                std::from_chars(count.data(), count.data() + count.size(), element.count);
            if (error != std::errc() || end != count.data() + count.size() ||
                element.count > uint64_t(std::numeric_limits<int64_t>::max()))
                problem("an element count that is not a non-negative integer within 2^63");
            for (const PlyElement& other : header.elements)
                if (other.name == element.name) problem("a second element of the same name");
            header.elements.push_back(std::move(element));
        } else if (words[0] == "property") {
            if (header.elements.empty()) problem("a property before any element");
            PlyProperty property;
            if (words.size() == 5 && words[1] == "list") {
                const auto countType = typeNamed(words[2]), type = typeNamed(words[3]);
                if (!countType || !type) problem("an unknown type");
                if (!isInteger(*countType)) problem("a list count of a non-integer type");
                property.isList = true;
                property.countType = *countType;
                property.type = *type;
                property.name = std::string(words[4]);
            } else if (words.size() == 3) {
                const auto type = typeNamed(words[1]);
                if (!type) problem("an unknown type");
                property.type = *type;
                property.name = std::string(words[2]);
            } else {
                problem(
                    "a malformed property (property TYPE NAME, or property list TYPE TYPE NAME)");
            }
            header.elements.back().properties.push_back(std::move(property));
        } else {
            problem("an unknown keyword");
        }
    }
    if (!sawFormat) fail("%s: the PLY header has no format line", name);
    header.dataOffset = position > bytes.size() ? bytes.size() : position;
    return header;
}

// The fewest bytes a row of `element` can take: a binary row its scalars and list counts (lists
// may be empty), an ASCII row one character and one separator a value.
uint64_t minimumRowBytes(const PlyElement& element, PlyFormat format) {
    uint64_t bytes = 0;
    for (const PlyProperty& property : element.properties)
        bytes += format == PlyFormat::Ascii
                     ? 2
                     : sizeOf(property.isList ? property.countType : property.type);
    return bytes;
}

// The values of the data after the header, read one at a time in order.
class PlyData {
  public:
    PlyData(std::string_view bytes, const PlyHeader& header, const std::string& name)
        : m_bytes(bytes),
          m_position(header.dataOffset),
          m_format(header.format),
          m_line(header.lines + 1),
          m_name(name) {}

    size_t remaining() const { return m_bytes.size() - m_position; }

    // The next value, of type `type`: an integer type's exactly, a float's as a double (a float
    // beyond the range of double reads as infinite). `what` names it for messages.
    double read(PlyType type, const char* what, uint64_t row) {
        return m_format == PlyFormat::Ascii ? readAscii(type, what, row)
                                            : readBinary(type, what, row);
    }

    // Where the reading is, for messages: a line of an ASCII file, an offset in a binary one.
    std::string where() const {
        return m_format == PlyFormat::Ascii ? absl::StrFormat("%s:%d", m_name, m_line)
                                            : absl::StrFormat("%s (byte %d)", m_name, m_position);
    }

  private:
    double readBinary(PlyType type, const char* what, uint64_t row) {
        const size_t size = sizeOf(type);
        if (remaining() < size)
            fail("%s: the file ends within %s of row %d: it is truncated", m_name, what, row);
        unsigned char raw[8];
        std::memcpy(raw, m_bytes.data() + m_position, size);
        m_position += size;
        const bool little = m_format == PlyFormat::LittleEndian;
        uint64_t bits = 0;
        for (size_t i = 0; i < size; ++i)
            bits |= uint64_t(raw[little ? i : size - 1 - i]) << (8 * i);
        switch (type) {
            case PlyType::Int8:
                return static_cast<int8_t>(bits);
            case PlyType::UInt8:
                return static_cast<uint8_t>(bits);
            case PlyType::Int16:
                return static_cast<int16_t>(bits);
            case PlyType::UInt16:
                return static_cast<uint16_t>(bits);
            case PlyType::Int32:
                return static_cast<int32_t>(bits);
            case PlyType::UInt32:
                return static_cast<uint32_t>(bits);
            case PlyType::Float32: {
                const uint32_t b = static_cast<uint32_t>(bits);
                float f;
                std::memcpy(&f, &b, sizeof f);
                return f;
            }
            case PlyType::Float64: {
                double d;
                std::memcpy(&d, &bits, sizeof d);
                return d;
            }
        }
        return 0.0;
    }

    double readAscii(PlyType type, const char* what, uint64_t row) {
        while (m_position < m_bytes.size() && isSpace(m_bytes[m_position])) {
            m_line += m_bytes[m_position] == '\n';
            ++m_position;
        }
        const size_t start = m_position;
        while (m_position < m_bytes.size() && !isSpace(m_bytes[m_position])) ++m_position;
        const std::string_view token = m_bytes.substr(start, m_position - start);
        if (token.empty())
            fail("%s: the file ends before %s of row %d: it is truncated", where(), what, row);
        const char* first = token.data();
        const char* last = token.data() + token.size();
        if (*first == '+' && token.size() > 1) ++first;  // from_chars takes no plus sign
        if (isInteger(type)) {
            int64_t value = 0;
            const auto [end, error] = std::from_chars(first, last, value);
            double lo, hi;
            integerRange(type, lo, hi);
            if (error != std::errc() || end != last || double(value) < lo || double(value) > hi)
                fail("%s: \"%s\" (%s of row %d) is not an integer within its type's range [%g, %g]",
                     where(), std::string(token.substr(0, 40)), what, row, lo, hi);
            return double(value);
        }
        double value = 0.0;
        const auto [end, error] = std::from_chars(first, last, value);
        // Beyond the range of double reads as infinite, to be refused where it matters.
        if (error == std::errc::result_out_of_range && end == last)
            return first[0] == '-' ? -std::numeric_limits<double>::infinity()
                                   : std::numeric_limits<double>::infinity();
        if (error != std::errc() || end != last)
            fail("%s: \"%s\" (%s of row %d) is not a number", where(),
                 std::string(token.substr(0, 40)), what, row);
        return value;
    }

    static bool isSpace(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

    std::string_view m_bytes;
    size_t m_position;
    PlyFormat m_format;
    size_t m_line;
    const std::string& m_name;
};

int findProperty(const PlyElement& element, std::string_view name) {
    for (size_t i = 0; i < element.properties.size(); ++i)
        if (element.properties[i].name == name) return static_cast<int>(i);
    return -1;
}

// A value for a float array: refused when not finite, or beyond the range of float.
float asFloat(double value, const PlyData& data, const char* what, uint64_t row) {
    if (!std::isfinite(value) || std::abs(value) > double(std::numeric_limits<float>::max()))
        fail("%s: %s of vertex %d is %g, which is not a finite float", data.where(), what, row,
             value);
    return static_cast<float>(value);
}

TriangleGeometry readPlyData(std::string_view bytes, const std::string& name) {
    const PlyHeader header = parseHeader(bytes, name);
    const uint64_t available = bytes.size() - header.dataOffset;

    // The counts against the file's size, before anything is allocated from them.
    uint64_t needed = 0;
    for (const PlyElement& element : header.elements) {
        const uint64_t row = minimumRowBytes(element, header.format);
        if (row != 0 && element.count > (std::numeric_limits<uint64_t>::max() - needed) / row)
            needed = std::numeric_limits<uint64_t>::max();
        else
            needed += row * element.count;
    }
    // The last ASCII value needs no separator after it.
    if (header.format == PlyFormat::Ascii && needed > 0) --needed;
    if (needed > available) {
        std::string counts;
        for (const PlyElement& element : header.elements)
            counts +=
                absl::StrFormat("%s%d %s", counts.empty() ? "" : ", ", element.count, element.name);
        fail(
            "%s: the PLY header declares %s, which take at least %d bytes, but the file has %d "
            "after its header: it is truncated or its counts are wrong",
            name, counts, needed, available);
    }

    const PlyElement* vertexElement = nullptr;
    const PlyElement* faceElement = nullptr;
    for (const PlyElement& element : header.elements) {
        if (element.name == "vertex") vertexElement = &element;
        if (element.name == "face") faceElement = &element;
    }
    if (!vertexElement) fail("%s: the PLY file has no \"vertex\" element", name);
    if (!faceElement) fail("%s: the PLY file has no \"face\" element (no triangles)", name);

    // Which property of a vertex row goes where: slot 0-2 position, 3-5 normal, 6-7 uv.
    std::vector<int> vertexSlot(vertexElement->properties.size(), -1);
    auto assign = [&](std::initializer_list<const char*> names, int firstSlot) {
        std::vector<int> found;
        for (const char* property : names) found.push_back(findProperty(*vertexElement, property));
        for (int index : found)
            if (index < 0) return false;
        for (size_t i = 0; i < found.size(); ++i) {
            if (vertexElement->properties[found[i]].isList)
                fail("%s: the vertex property \"%s\" is a list; it must be a single number", name,
                     vertexElement->properties[found[i]].name);
            vertexSlot[found[i]] = firstSlot + static_cast<int>(i);
        }
        return true;
    };
    if (!assign({"x", "y", "z"}, 0))
        fail("%s: the PLY vertex element lacks one of the properties x, y and z", name);
    const bool hasNormals = assign({"nx", "ny", "nz"}, 3);
    const bool hasUvs = assign({"u", "v"}, 6) || assign({"s", "t"}, 6) ||
                        assign({"texture_u", "texture_v"}, 6) ||
                        assign({"texture_s", "texture_t"}, 6);

    int indexProperty = findProperty(*faceElement, "vertex_indices");
    if (indexProperty < 0) indexProperty = findProperty(*faceElement, "vertex_index");
    if (indexProperty < 0)
        fail("%s: the PLY face element has no \"vertex_indices\" (or \"vertex_index\") list", name);
    const PlyProperty& indices = faceElement->properties[indexProperty];
    if (!indices.isList || !isInteger(indices.type))
        fail("%s: the PLY face property \"%s\" must be a list of integers", name, indices.name);

    // The vertex arrays fit: the count was checked against the file's size above. Vertex
    // indices are uint32: more vertices could not all be named.
    const uint64_t vertexCount = vertexElement->count;
    if (vertexCount > std::numeric_limits<uint32_t>::max())
        fail("%s: the PLY file has %d vertices; at most %d are supported", name, vertexCount,
             std::numeric_limits<uint32_t>::max());
    TriangleGeometry geometry;
    geometry.positions.resize(3, static_cast<Eigen::Index>(vertexCount));
    geometry.normals.resize(3, hasNormals ? static_cast<Eigen::Index>(vertexCount) : 0);
    geometry.uvs.resize(2, hasUvs ? static_cast<Eigen::Index>(vertexCount) : 0);
    std::vector<uint32_t> triangles;

    static const char* const kSlotNames[] = {"x", "y", "z", "nx", "ny", "nz", "u", "v"};
    PlyData data(bytes, header, name);
    std::vector<uint32_t> polygon;
    for (const PlyElement& element : header.elements) {
        // An element without properties has nothing to read, however large its count.
        if (element.properties.empty()) continue;
        const bool isVertex = &element == vertexElement, isFace = &element == faceElement;
        for (uint64_t row = 0; row < element.count; ++row) {
            for (size_t p = 0; p < element.properties.size(); ++p) {
                const PlyProperty& property = element.properties[p];
                const char* what = property.name.c_str();
                if (!property.isList) {
                    const double value = data.read(property.type, what, row);
                    const int slot = isVertex ? vertexSlot[p] : -1;
                    if (slot < 0) continue;
                    const float f = asFloat(value, data, kSlotNames[slot], row);
                    const Eigen::Index column = static_cast<Eigen::Index>(row);
                    if (slot < 3)
                        geometry.positions(slot, column) = f;
                    else if (slot < 6)
                        geometry.normals(slot - 3, column) = f;
                    else
                        geometry.uvs(slot - 6, column) = f;
                    continue;
                }
                const double length = data.read(property.countType, what, row);
                if (length < 0)
                    fail("%s: the list %s of row %d has a negative length (%g)", data.where(), what,
                         row, length);
                // The items must be in the file: a long list is refused before it is read.
                const uint64_t itemBytes =
                    header.format == PlyFormat::Ascii ? 2 : sizeOf(property.type);
                if (length * double(itemBytes) > double(data.remaining()) + 1.0)
                    fail(
                        "%s: the list %s of row %d holds %g items, more than the rest of the "
                        "file can: it is truncated or the length is wrong",
                        data.where(), what, row, length);
                const uint64_t items = static_cast<uint64_t>(length);
                const bool isIndices = isFace && static_cast<int>(p) == indexProperty;
                if (isIndices && items < 3)
                    fail("%s: face %d has %d vertices; a face needs at least 3", data.where(), row,
                         items);
                polygon.clear();
                for (uint64_t i = 0; i < items; ++i) {
                    const double value = data.read(property.type, what, row);
                    if (!isIndices) continue;
                    if (value < 0 || value >= double(vertexCount))
                        fail(
                            "%s: face %d uses vertex %g, but the file has %d vertices (indices "
                            "0 to %d)",
                            data.where(), row, value, vertexCount,
                            static_cast<int64_t>(vertexCount) - 1);
                    polygon.push_back(static_cast<uint32_t>(value));
                }
                if (!isIndices) continue;
                for (size_t k = 2; k < polygon.size(); ++k) {
                    triangles.push_back(polygon[0]);
                    triangles.push_back(polygon[k - 1]);
                    triangles.push_back(polygon[k]);
                }
            }
        }
    }
    if (triangles.empty()) fail("%s: the PLY file has no faces", name);
    if (triangles.size() / 3 > uint64_t(std::numeric_limits<Eigen::Index>::max()))
        fail("%s: too many triangles", name);
    geometry.faces.resize(3, static_cast<Eigen::Index>(triangles.size() / 3));
    std::copy(triangles.begin(), triangles.end(), geometry.faces.data());
    return geometry;
}

bool isGzip(std::string_view bytes) {
    return bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0x1f &&
           static_cast<unsigned char>(bytes[1]) == 0x8b;
}

// Inflates gzip data (one member or several in a row) through a small buffer, handing each
// piece to `consume`, and refuses it as soon as it goes beyond `cap` bytes. Returns the size.
template <typename Consume>
uint64_t inflateGzip(std::string_view bytes, const std::string& name, uint64_t cap,
                     Consume&& consume) {
    z_stream stream{};
    // 16 + MAX_WBITS: deflate data in a gzip header and trailer.
    if (inflateInit2(&stream, 16 + MAX_WBITS) != Z_OK)
        fail("%s: cannot start decompressing the gzip-compressed file", name);
    struct End {
        z_stream& stream;
        ~End() { inflateEnd(&stream); }
    } end{stream};
    std::vector<unsigned char> buffer(1 << 18);
    uint64_t consumed = 0, produced = 0;
    while (true) {
        constexpr uint64_t kStep = uint64_t(1) << 30;  // what one zlib call takes at most
        stream.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(bytes.data() + consumed));
        stream.avail_in = static_cast<uInt>(std::min<uint64_t>(bytes.size() - consumed, kStep));
        stream.next_out = buffer.data();
        stream.avail_out = static_cast<uInt>(buffer.size());
        const uInt inBefore = stream.avail_in;
        const int status = inflate(&stream, Z_NO_FLUSH);
        consumed += inBefore - stream.avail_in;
        const size_t piece = buffer.size() - stream.avail_out;
        produced += piece;
        if (produced > cap)
            fail(
                "%s: the gzip-compressed file inflates to more than %d bytes, the most allowed "
                "for a file of %d bytes (%d times its size plus %d MiB, and at most %d GiB)",
                name, cap, bytes.size(), kMaxPlyInflationRatio, kPlyInflationAllowance >> 20,
                kMaxPlyInflatedBytes >> 30);
        consume(reinterpret_cast<const char*>(buffer.data()), piece);
        if (status == Z_STREAM_END) {
            // Another gzip member may follow: concatenated gzip files are one gzip file.
            if (!isGzip(bytes.substr(consumed))) break;
            if (inflateReset(&stream) != Z_OK) fail("%s: cannot decompress the file", name);
            continue;
        }
        if (status == Z_OK) continue;
        // No progress with room to write into: the input ran out.
        if (status == Z_BUF_ERROR)
            fail("%s: the gzip-compressed data ends early: the file is truncated", name);
        fail("%s: the gzip-compressed data is corrupt (zlib: %s)", name,
             stream.msg ? stream.msg : "error");
    }
    return produced;
}

// The inflated content of gzip data, within the cap. It is inflated twice, first only to be
// measured: a file beyond the cap is refused without memory taken for it, and the content is
// then written once into memory of its exact size.
std::string inflated(std::string_view bytes, const std::string& name) {
    const uint64_t cap =
        std::min<uint64_t>(kMaxPlyInflatedBytes,
                           uint64_t(bytes.size()) * kMaxPlyInflationRatio + kPlyInflationAllowance);
    const uint64_t size = inflateGzip(bytes, name, cap, [](const char*, size_t) {});
    std::string out;
    out.reserve(size);
    inflateGzip(bytes, name, size, [&](const char* data, size_t n) { out.append(data, n); });
    return out;
}

}  // namespace

TriangleGeometry readPlyBytes(std::string_view bytes, const std::string& name) {
    if (isGzip(bytes)) {
        const std::string content = inflated(bytes, name);
        return readPlyData(content, name);
    }
    return readPlyData(bytes, name);
}

TriangleGeometry readPlyFile(const std::string& path, const std::string& name) {
    std::error_code error;
    const auto status = std::filesystem::status(path, error);
    if (status.type() == std::filesystem::file_type::not_found)
        fail("%s: cannot open: the file does not exist", name);
    if (error) fail("%s: cannot open: %s", name, error.message());
    if (!std::filesystem::is_regular_file(status))
        fail("%s: cannot open: it is not a regular file", name);
    std::ifstream file(path, std::ios::binary | std::ios::ate);
    if (!file) fail("%s: cannot open: %s", name, std::strerror(errno));
    const std::streamoff size = file.tellg();
    file.seekg(0);
    std::string bytes(size > 0 ? static_cast<size_t>(size) : 0, '\0');
    file.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (static_cast<size_t>(file.gcount()) != bytes.size())
        fail("%s: cannot read: the file changed while being read", name);
    return readPlyBytes(bytes, name);
}

}  // namespace alphorn
