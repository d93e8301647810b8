// afm_media: what OpenCV reads back from the bench's outputs.
//   afm_media frames VIDEO    prints the number of frames decoded and their size
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <cstdio>
#include <string>

#include "command_line.hpp"

namespace {

struct Options {
    std::string command, video;
};

const afm::cli::CommandLine<Options> kCommandLine = {
    "afm_media",
    "usage: afm_media frames VIDEO\n  prints the frame count OpenCV decodes, then width and height\n",
    {
        {{"COMMAND", nullptr, nullptr, nullptr, true}, afm::cli::choice(&Options::command, {"frames"})},
        {{"VIDEO", nullptr, nullptr, nullptr, true}, afm::cli::text(&Options::video)},
    }};

}  // namespace

int main(int argc, char **argv)
{
    Options o;
    if (const int code = afm::cli::read_command_line(kCommandLine, argc, argv, &o); code >= 0) return code;
    cv::VideoCapture cap(o.video);
    if (!cap.isOpened()) {
        std::fprintf(stderr, "afm_media: cannot open video %s\n", o.video.c_str());
        return 1;
    }
    cv::Mat f;
    int n = 0, w = 0, h = 0;
    while (cap.read(f)) {
        ++n;
        w = f.cols;
        h = f.rows;
    }
    std::printf("%d %d %d\n", n, w, h);
    return 0;
}
