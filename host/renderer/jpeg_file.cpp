#include "jpeg_file.hpp"

#include <cstdio>
#include <csetjmp>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include <jpeglib.h>

namespace afm {

namespace {

// libjpeg's error manager, whose error_exit jumps back instead of exiting.
struct JumpingErrors {
    jpeg_error_mgr mgr;
    std::jmp_buf back;
    char message[JMSG_LENGTH_MAX];
};

void jump_back(j_common_ptr c)
{
    auto *e = reinterpret_cast<JumpingErrors *>(c->err);
    (*c->err->format_message)(c, e->message);
    std::longjmp(e->back, 1);
}

// Compresses img into *mem / *size (libjpeg's memory destination, malloc'd);
// false with e->message set on libjpeg's error.
bool compress(const cv::Mat &img, int quality, JumpingErrors *e, unsigned char **mem, unsigned long *size)
{
    jpeg_compress_struct c;
    c.err = jpeg_std_error(&e->mgr);
    e->mgr.error_exit = jump_back;
    if (setjmp(e->back) != 0) {
        jpeg_destroy_compress(&c);
        return false;
    }
    jpeg_create_compress(&c);
    jpeg_mem_dest(&c, mem, size);
    c.image_width = static_cast<JDIMENSION>(img.cols);
    c.image_height = static_cast<JDIMENSION>(img.rows);
    c.input_components = img.channels();
    c.in_color_space = img.channels() == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
    jpeg_set_defaults(&c);
    jpeg_set_quality(&c, quality, TRUE);
    jpeg_start_compress(&c, TRUE);
    while (c.next_scanline < c.image_height) {
        JSAMPROW row = const_cast<JSAMPROW>(img.ptr<unsigned char>(static_cast<int>(c.next_scanline)));
        jpeg_write_scanlines(&c, &row, 1);
    }
    jpeg_finish_compress(&c);
    jpeg_destroy_compress(&c);
    return true;
}

}  // namespace

std::vector<unsigned char> encode_jpeg(const cv::Mat &img, int quality)
{
    if (img.empty() || img.dims != 2 || (img.type() != CV_8UC3 && img.type() != CV_8UC1))
        throw std::invalid_argument("encode_jpeg: an 8-bit image of 1 or 3 channels, not type " + std::to_string(img.type()) +
                                    (img.empty() ? " (empty)" : ""));
    JumpingErrors e{};
    unsigned char *mem = nullptr;
    unsigned long size = 0;
    const bool ok = compress(img, quality, &e, &mem, &size);
    std::vector<unsigned char> out;
    if (ok) out.assign(mem, mem + size);
    std::free(mem);
    if (!ok) throw std::runtime_error(std::string("encode_jpeg: libjpeg: ") + e.message);
    return out;
}

}  // namespace afm
