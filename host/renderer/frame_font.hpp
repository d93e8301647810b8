// The text of the frames and figures: DejaVu Sans (Debian's
// fonts-dejavu-core, kFontFile) drawn by OpenCV's FreeType module
// (cv::freetype, Debian's libopencv-contrib-dev), anti-aliased, in UTF-8
// (µm, the minus sign U+2212).
//
// At a font size (font_px: FreeType's pixel size, the em; a capital of
// DejaVu Sans is 0.73 of it) each character is rendered once by
// cv::freetype into a coverage mask, with its advance; a text is its
// characters' masks put together at their advances (as cv::freetype
// places them: it does not kern) and kept (per thread, at most
// kMaxCachedTexts; past that the cache starts anew). The frames' axes,
// units and ids are the same every frame; the few texts that change (time,
// forces) cost a copy of their glyphs, not FreeType's rendering.
//
// Where a text lies: its origin is the left end of its baseline (as
// cv::putText's); ink_box() is the box of the pixels its glyphs cover,
// exactly the mask drawn. Every text a frame or figure draws is recorded
// as a TextBox (its ink box and size), so that a test measures what was
// drawn: the smallest capital, and that no two texts touch.
//
// Errors: the font file missing or unreadable throws std::runtime_error
// naming it, at the first text drawn (the renderer's first figure, before
// the run's first block).
#pragma once

#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace afm {

inline constexpr const char *kFontFile = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
constexpr std::size_t kMaxCachedTexts = 1024;
constexpr int kTextGapPx = 2;                 // between two texts' inks (and a text and a tick), pixels at least
inline const cv::Scalar kBlack(0, 0, 0);      // a figure's texts and lines, on white

struct TextMask {
    cv::Mat a;          // coverage 0-255 (CV_8U): the glyphs, anti-aliased
    cv::Mat outline;    // a dilated by a pixel: the dark outline under a label
    cv::Point offset;   // a's top-left corner from the origin
    cv::Rect ink;       // the covered pixels' box, from the origin (empty for blank text)
};
const TextMask &text_mask(const std::string &text, int font_px);

// The box text covers when drawn with its origin at org.
cv::Rect ink_box(const std::string &text, int font_px, cv::Point org);
// The height of a capital (the ink of "H"), pixels.
int cap_height_px(int font_px);

// Text in colour c over the image (a figure's, on white): no outline.
void draw_text(cv::Mat &bgr, const std::string &text, cv::Point org, int font_px, const cv::Scalar &c);
// A label's pixel: the channel p under an outline of opacity o (0-255)
// darkened to p (255 - o) / 255, then text of opacity t in colour c (a whole
// 0-255 value) over it, rounded to the nearest byte. Exactly
// (p (255 - o) (255 - t) + 255 c t) / 65025, which is never a tie (65025
// is odd): the bytes of the same formula evaluated in doubles, in integers.
inline unsigned char label_blend(int p, int o, int t, int c)
{
    const int n = p * (255 - o) * (255 - t) + 255 * c * t;
    return static_cast<unsigned char>((2 * n + 65025) / 130050);
}

// Text legible on any colour of a map: its outline darkened under it, then
// the text in colour c (label_blend; c's channels whole, 0-255).
void draw_label(cv::Mat &bgr, const std::string &text, cv::Point org, int font_px, const cv::Scalar &c);

// A text as drawn: what it says, what it is (role: "x tick", "y tick",
// "axis unit", "status", "legend", "lever", "id", "bar", "title", ...),
// the box of its ink and its font size.
struct TextBox {
    std::string text, role;
    cv::Rect ink;
    int font_px;
};

// A number for an axis or a colour bar: "%g", a negative one with the
// minus sign (U+2212), never a hyphen; -0 as 0.
std::string axis_number(double v);
// A label's text: printf's format f (one conversion, of a double) with v,
// cut at 95 bytes.
std::string label_number(const char *f, double v);

}  // namespace afm
