#include "png_read.hpp"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <vector>

namespace afm {

namespace {

// The transforms OpenCV's PNG decoder asks of libpng for an 8-bit image of
// 1 or 3 channels (png_read.hpp); then the header as transformed.
void ask_transforms(png_structp png, png_infop info, bool colour)
{
    const int depth = png_get_bit_depth(png, info), type = png_get_color_type(png, info);
    if (depth == 16) png_set_strip_16(png);
    png_set_strip_alpha(png);
    if (type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if ((type & PNG_COLOR_MASK_COLOR) == 0 && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if ((type & PNG_COLOR_MASK_COLOR) && colour) png_set_bgr(png);
    else if (colour) png_set_gray_to_rgb(png);
    else png_set_rgb_to_gray(png, 1, 0.299, 0.587);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
}

// Reads the file's image into *out (sized here, before any longjmp can
// skip a destructor); false on any libpng error.
bool read_into(std::FILE *f, bool colour, cv::Mat *out, std::vector<png_bytep> *rows)
{
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    if (!png) return false;
    png_infop info = png_create_info_struct(png);
    volatile bool ok = false;   // read after a longjmp
    if (info && setjmp(png_jmpbuf(png)) == 0) {
        png_init_io(png, f);
        png_read_info(png, info);
        ask_transforms(png, info, colour);
        const int w = static_cast<int>(png_get_image_width(png, info)), h = static_cast<int>(png_get_image_height(png, info));
        if (png_get_rowbytes(png, info) == static_cast<png_size_t>(w) * (colour ? 3 : 1)) {
            out->create(h, w, colour ? CV_8UC3 : CV_8UC1);
            rows->resize(static_cast<std::size_t>(h));
            for (int y = 0; y < h; ++y) (*rows)[static_cast<std::size_t>(y)] = out->ptr(y);
            png_read_image(png, rows->data());
            png_read_end(png, nullptr);
            ok = true;
        }
    }
    png_destroy_read_struct(&png, info ? &info : nullptr, nullptr);
    return ok;
}

}  // namespace

cv::Mat read_png(const std::string &path, bool colour)
{
    std::FILE *f = std::fopen(path.c_str(), "rb");
    if (!f) return {};
    unsigned char sig[8];
    cv::Mat img;
    std::vector<png_bytep> rows;
    bool ok = std::fread(sig, 1, sizeof sig, f) == sizeof sig && png_sig_cmp(sig, 0, sizeof sig) == 0;
    if (ok) {
        std::rewind(f);
        ok = read_into(f, colour, &img, &rows);
    }
    std::fclose(f);
    return ok ? img : cv::Mat();
}

}  // namespace afm
