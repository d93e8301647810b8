#include "frame_font.hpp"

#include <opencv2/freetype.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <memory>
#include <stdexcept>
#include <utility>

namespace afm {

namespace {

cv::freetype::FreeType2 &font()
{
    static thread_local cv::Ptr<cv::freetype::FreeType2> ft;
    if (!ft) {
        if (!std::ifstream(kFontFile).good())
            throw std::runtime_error(std::string("frame font: cannot read ") + kFontFile + " (Debian's fonts-dejavu-core; tools/setup.sh installs it)");
        cv::Ptr<cv::freetype::FreeType2> f = cv::freetype::createFreeType2();
        f->loadFontData(kFontFile, 0);
        ft = f;
    }
    return *ft;
}

// The text's coverage, drawn with cv::freetype's point `at` at (pad, pad)
// of a buffer with room all round (FreeType's size is the advance and the
// em, not the ink); its ink's box in the buffer.
cv::Mat coverage(const std::string &text, int font_px, int pad, cv::Rect *ink)
{
    int baseline = 0;
    const cv::Size sz = font().getTextSize(text, font_px, -1, &baseline);
    cv::Mat bgr = cv::Mat::zeros(3 * font_px + 2 * pad, sz.width + 2 * pad + font_px, CV_8UC3);
    font().putText(bgr, text, cv::Point(pad, pad), font_px, cv::Scalar(255, 255, 255), -1, cv::LINE_AA, false);
    cv::Mat a;
    cv::extractChannel(bgr, a, 0);
    *ink = cv::boundingRect(a);
    return a;
}

// How far below cv::freetype's point the baseline lies: where a capital's ink ends.
int baseline_below(int font_px)
{
    static thread_local std::map<int, int> known;
    auto it = known.find(font_px);
    if (it != known.end()) return it->second;
    cv::Rect ink;
    coverage("H", font_px, font_px, &ink);
    return known[font_px] = ink.br().y - font_px;
}

// One text rendered whole by cv::freetype: its mask and ink from the origin.
TextMask render(const std::string &text, int font_px)
{
    TextMask m;
    if (text.empty() || font_px <= 0) return m;
    const int pad = font_px;
    cv::Rect ink;
    const cv::Mat a = coverage(text, font_px, pad, &ink);
    const cv::Point org(pad, pad + baseline_below(font_px));   // the baseline's left end in the buffer
    if (ink.empty()) return m;
    // the mask: the ink and a pixel round it (the outline's room)
    const cv::Rect keep = cv::Rect(ink.x - 1, ink.y - 1, ink.width + 2, ink.height + 2) & cv::Rect(0, 0, a.cols, a.rows);
    m.a = a(keep).clone();
    m.offset = keep.tl() - org;
    m.ink = cv::Rect(ink.tl() - org, ink.size());
    return m;
}

// A glyph: its mask (as render's) and its advance, pixels. cv::freetype
// places each glyph at the previous one's advance (no kerning), so a text
// put together from its glyphs is the text it renders.
struct Glyph {
    TextMask m;
    int advance = 0;
};

const Glyph &glyph(const std::string &ch, int font_px)
{
    static thread_local std::map<std::pair<std::string, int>, Glyph> glyphs;
    auto it = glyphs.find({ch, font_px});
    if (it != glyphs.end()) return it->second;
    Glyph g;
    g.m = render(ch, font_px);
    // the advance: how much further a bar after it stands than a bar after a bar
    int base = 0;
    g.advance = font().getTextSize("|" + ch + "|", font_px, -1, &base).width - font().getTextSize("||", font_px, -1, &base).width;
    return glyphs.emplace(std::make_pair(ch, font_px), std::move(g)).first->second;
}

// The UTF-8 sequences of a text, one a character.
std::vector<std::string> characters(const std::string &text)
{
    std::vector<std::string> out;
    for (std::size_t i = 0; i < text.size();) {
        const unsigned char c = static_cast<unsigned char>(text[i]);
        const std::size_t n = c < 0x80 ? 1 : c < 0xE0 ? 2 : c < 0xF0 ? 3 : 4;
        out.push_back(text.substr(i, n));
        i += n;
    }
    return out;
}

// A text put together from its glyphs' masks (each rendered once).
TextMask compose(const std::string &text, int font_px)
{
    struct Placed {
        const TextMask *m;
        int x;
    };
    std::vector<Placed> placed;
    cv::Rect box;
    int x = 0;
    for (const std::string &ch : characters(text)) {
        const Glyph &g = glyph(ch, font_px);
        if (!g.m.a.empty()) {
            placed.push_back({&g.m, x});
            const cv::Rect r(g.m.offset + cv::Point(x, 0), g.m.a.size());
            box = box.empty() ? r : (box | r);
        }
        x += g.advance;
    }
    TextMask m;
    if (placed.empty()) return m;
    m.a = cv::Mat::zeros(box.size(), CV_8U);
    cv::Rect ink;
    for (const Placed &p : placed) {
        const cv::Rect r(p.m->offset + cv::Point(p.x, 0) - box.tl(), p.m->a.size());
        cv::Mat dst = m.a(r);
        cv::max(dst, p.m->a, dst);
        const cv::Rect gi = p.m->ink + cv::Point(p.x, 0);
        ink = ink.empty() ? gi : (ink | gi);
    }
    m.offset = box.tl();
    m.ink = ink;
    return m;
}

}  // namespace

const TextMask &text_mask(const std::string &text, int font_px)
{
    static thread_local std::map<std::pair<std::string, int>, TextMask> cache;
    auto it = cache.find({text, font_px});
    if (it != cache.end()) return it->second;
    if (cache.size() >= kMaxCachedTexts) cache.clear();
    TextMask m = font_px > 0 ? compose(text, font_px) : TextMask{};
    if (!m.a.empty()) cv::dilate(m.a, m.outline, cv::Mat());
    return cache.emplace(std::make_pair(text, font_px), std::move(m)).first->second;
}

cv::Rect ink_box(const std::string &text, int font_px, cv::Point org)
{
    const cv::Rect r = text_mask(text, font_px).ink;
    return r.empty() ? cv::Rect(org, cv::Size()) : cv::Rect(r.tl() + org, r.size());
}

int cap_height_px(int font_px)
{
    return glyph("H", font_px).m.ink.height;
}

namespace {

// Blends the mask at org: the outline (if any) towards black, the text towards c.
void blend(cv::Mat &img, const TextMask &m, cv::Point org, const cv::Scalar &colour, bool outlined)
{
    CV_Assert(img.type() == CV_8UC3);
    if (m.a.empty()) return;
    const cv::Rect box(org + m.offset, m.a.size());
    const cv::Rect on = box & cv::Rect(0, 0, img.cols, img.rows);
    if (on.empty()) return;
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = static_cast<int>(std::lround(std::clamp(colour[k], 0.0, 255.0)));
    for (int y = on.y; y < on.br().y; ++y) {
        cv::Vec3b *px = img.ptr<cv::Vec3b>(y) + on.x;
        const uchar *t = m.a.ptr<uchar>(y - box.y) + (on.x - box.x);
        const uchar *o = m.outline.ptr<uchar>(y - box.y) + (on.x - box.x);
        for (int x = 0; x < on.width; ++x) {
            const int ox = outlined ? o[x] : 0;
            if (!ox && !t[x]) continue;
            for (int k = 0; k < 3; ++k) px[x][k] = label_blend(px[x][k], ox, t[x], c[k]);
        }
    }
}

}  // namespace

void draw_text(cv::Mat &bgr, const std::string &text, cv::Point org, int font_px, const cv::Scalar &c)
{
    blend(bgr, text_mask(text, font_px), org, c, false);
}

void draw_label(cv::Mat &bgr, const std::string &text, cv::Point org, int font_px, const cv::Scalar &c)
{
    blend(bgr, text_mask(text, font_px), org, c, true);
}

std::string axis_number(double v)
{
    if (std::fabs(v) < 1e-9) return "0";
    char b[48];
    std::snprintf(b, sizeof b, "%g", std::fabs(v));
    return v < 0 ? std::string("\u2212") + b : std::string(b);
}

std::string label_number(const char *f, double v)
{
    char b[96];
    std::snprintf(b, sizeof b, f, v);
    return b;
}

}  // namespace afm
