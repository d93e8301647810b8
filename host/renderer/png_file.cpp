#include "png_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <isa-l/igzip_lib.h>
#include <opencv2/imgproc.hpp>
#include <unistd.h>
#include <zlib.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

namespace afm {

namespace {

constexpr std::uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
constexpr std::uint8_t kFilterSub = 1;   // each byte less the byte of the pixel to its left
constexpr int kMaxSide = 65535;
constexpr std::size_t kInputPad = 64;    // zero bytes after the rows, for ISA-L's loads (deflate_zlib)          // far above any display (scene.cpp: image_px <= 4096)

void put_u32(std::vector<std::uint8_t> &out, std::uint32_t v)
{
    out.push_back(static_cast<std::uint8_t>(v >> 24));
    out.push_back(static_cast<std::uint8_t>(v >> 16));
    out.push_back(static_cast<std::uint8_t>(v >> 8));
    out.push_back(static_cast<std::uint8_t>(v));
}

// A chunk: its length, type, data and the CRC-32 of type and data.
// Scaling and overflow: the length is a 32-bit field (PNG allows up to
// 2^31 - 1); encode_png refuses images of more than 1e9 samples, so the
// IDAT (at most the filtered rows plus deflate's stored-block headers)
// stays below it.
void put_chunk(std::vector<std::uint8_t> &out, const char type[4], const std::uint8_t *data, std::size_t n)
{
    put_u32(out, static_cast<std::uint32_t>(n));
    const std::size_t at = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data, data + n);
    const uLong crc = crc32(crc32(0L, Z_NULL, 0), out.data() + at, static_cast<uInt>(4 + n));
    put_u32(out, static_cast<std::uint32_t>(crc));
}

// The scanlines as PNG filters them: a filter-type byte, then each row's
// samples in PNG's order (RGB, RGBA: OpenCV's cvtColor turns BGR(A) into
// it) less those of the pixel to the left (modulo 256: the Sub filter),
// into raw (resized to fit, and followed by kInputPad zero bytes). The
// subtraction runs over contiguous bytes, which the compiler vectorizes.
void filter_rows(const cv::Mat &img, std::vector<std::uint8_t> &raw)
{
    thread_local cv::Mat rgb;
    const int ch = img.channels();
    const cv::Mat *src = &img;
    if (ch > 1) {
        cv::cvtColor(img, rgb, ch == 3 ? cv::COLOR_BGR2RGB : cv::COLOR_BGRA2RGBA);
        src = &rgb;
    }
    const std::size_t row = static_cast<std::size_t>(img.cols) * ch;
    const std::size_t n = (row + 1) * img.rows;
    raw.resize(n + kInputPad);
    std::memset(raw.data() + n, 0, kInputPad);
    for (int y = 0; y < img.rows; ++y) {
        const std::uint8_t *p = src->ptr<std::uint8_t>(y);
        std::uint8_t *o = raw.data() + (row + 1) * y;
        *o++ = kFilterSub;
        std::memcpy(o, p, static_cast<std::size_t>(ch));
        for (std::size_t i = ch; i < row; ++i) o[i] = static_cast<std::uint8_t>(p[i] - p[i - ch]);
    }
}

// The zlib stream of the first n bytes of `raw` (RFC 1950 around RFC
// 1951), ISA-L's level 1 in one call, into out (resized to fit). Its
// output is at most the input plus stored blocks' headers (igzip_lib.h:
// isal_deflate_stateless), bounded here with room to spare.
//
// The same image gives the same bytes whatever ran before (frames are
// compared byte for byte with encode_png, and runs replay bit for bit):
// isal_deflate_stateless_init leaves most of the stream's internal state
// as it found it, so the stream starts zeroed; the level buffer's header
// and hash table (its first ISAL_DEF_LVL1_REQ bytes; the token buffer
// after them is written before it is read) are zeroed, which is what
// ISA-L's own reset writes at total_in 0; and the input is followed by
// kInputPad zero bytes of raw, so a vector load past its end reads
// zeros, not the previous image. On the 2-core CI machine, whose CPU
// takes another of ISA-L's code paths than the development machine's,
// two encodings of one 4 x 4 image once differed with these reused.

void deflate_zlib(const std::vector<std::uint8_t> &raw, std::size_t n, std::vector<std::uint8_t> &out)
{
    thread_local std::vector<std::uint8_t> level_buf(ISAL_DEF_LVL1_DEFAULT);
    std::memset(level_buf.data(), 0, ISAL_DEF_LVL1_REQ);
    out.resize(n + 5 * (n / 16383 + 1) + ISAL_DEF_MAX_HDR_SIZE + 64);
    isal_zstream s{};
    isal_deflate_stateless_init(&s);
    s.level = 1;
    s.level_buf = level_buf.data();
    s.level_buf_size = static_cast<std::uint32_t>(level_buf.size());
    s.gzip_flag = IGZIP_ZLIB;
    s.end_of_stream = 1;
    s.flush = NO_FLUSH;
    s.next_in = const_cast<std::uint8_t *>(raw.data());
    s.avail_in = static_cast<std::uint32_t>(n);
    s.next_out = out.data();
    s.avail_out = static_cast<std::uint32_t>(out.size());
    if (const int r = isal_deflate_stateless(&s); r != COMP_OK)
        throw std::runtime_error("PNG: ISA-L's deflate failed (code " + std::to_string(r) + ") on " + std::to_string(n) + " bytes");
    out.resize(s.total_out);
}

}  // namespace

std::vector<std::uint8_t> encode_png(const cv::Mat &img)
{
    if (img.empty()) throw std::invalid_argument("PNG: the image is empty");
    if (img.dims != 2) throw std::invalid_argument("PNG: the image has " + std::to_string(img.dims) + " dimensions, not 2");
    if (img.depth() != CV_8U || (img.channels() != 1 && img.channels() != 3 && img.channels() != 4))
        throw std::invalid_argument("PNG: only 8-bit grey, BGR or BGRA images are written, got type " + cv::typeToString(img.type()));
    if (img.cols > kMaxSide || img.rows > kMaxSide || static_cast<double>(img.total()) * img.channels() > 1.0e9)
        throw std::invalid_argument("PNG: the image is " + std::to_string(img.cols) + " x " + std::to_string(img.rows) +
                                    " px; at most 65535 px a side and 1e9 samples are written");
    // a frame's rows and their deflate are 0.2 MB at 256 px: kept for the
    // thread's next image, not taken from and given back to the system
    // (above glibc's mmap threshold, each would cost page faults)
    thread_local std::vector<std::uint8_t> raw, idat;
    filter_rows(img, raw);
    deflate_zlib(raw, raw.size() - kInputPad, idat);

    std::vector<std::uint8_t> out(kSignature, kSignature + 8);
    out.reserve(8 + 25 + 12 + idat.size() + 12);
    std::vector<std::uint8_t> ihdr;
    put_u32(ihdr, static_cast<std::uint32_t>(img.cols));
    put_u32(ihdr, static_cast<std::uint32_t>(img.rows));
    const std::uint8_t colour_type = img.channels() == 1 ? 0 : img.channels() == 3 ? 2 : 6;
    for (std::uint8_t b : {std::uint8_t{8}, colour_type, std::uint8_t{0}, std::uint8_t{0}, std::uint8_t{0}}) ihdr.push_back(b);
    put_chunk(out, "IHDR", ihdr.data(), ihdr.size());
    put_chunk(out, "IDAT", idat.data(), idat.size());
    put_chunk(out, "IEND", nullptr, 0);
    return out;
}

void write_png(const std::string &path, const cv::Mat &img)
{
    const std::vector<std::uint8_t> bytes = encode_png(img);
    const int fd = open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw std::runtime_error("cannot write " + path + ": " + std::strerror(errno));
    std::size_t done = 0;
    int err = 0;
    while (done < bytes.size()) {
        const ssize_t n = write(fd, bytes.data() + done, bytes.size() - done);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            err = n < 0 ? errno : EIO;
            break;
        }
        done += static_cast<std::size_t>(n);
    }
    struct stat st {};
    const bool regular = fstat(fd, &st) == 0 && S_ISREG(st.st_mode);
    if (close(fd) != 0 && err == 0) err = errno;
    if (err != 0) {
        if (regular) unlink(path.c_str());   // not half a PNG (and never a device such as /dev/full)
        throw std::runtime_error("cannot write " + path + ": " + std::strerror(err));
    }
}

}  // namespace afm
