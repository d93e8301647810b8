// afm_media: what OpenCV reads back from the bench's outputs.
//   afm_media frames VIDEO    prints the number of frames decoded and their size
#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include <cstdio>
#include <string>

int main(int argc, char **argv)
{
    if (argc != 3 || std::string(argv[1]) != "frames") {
        std::fprintf(stderr, "usage: afm_media frames VIDEO\n  prints the frame count OpenCV decodes, then width and height\n");
        return 2;
    }
    cv::VideoCapture cap(argv[2]);
    if (!cap.isOpened()) {
        std::fprintf(stderr, "afm_media: cannot open video %s\n", argv[2]);
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
