// compare_crop WHOLE.exr CROP.exr X0 Y0: exits 0 when every pixel of CROP equals, bit for bit,
// the pixel of WHOLE at (X0 + x, Y0 + y), and says which differs otherwise (cli.crop).
#include "common/core/image.h"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>

int main(int argc, char** argv) {
    if (argc != 5) {
        std::fprintf(stderr, "usage: %s WHOLE.exr CROP.exr X0 Y0\n", argv[0]);
        return 2;
    }
    try {
        const alphorn::Image whole = alphorn::readEXR(argv[1]);
        const alphorn::Image crop = alphorn::readEXR(argv[2]);
        const int x0 = std::atoi(argv[3]), y0 = std::atoi(argv[4]);
        if (x0 + crop.width > whole.width || y0 + crop.height > whole.height) {
            std::fprintf(stderr, "a %dx%d crop at (%d, %d) does not fit the %dx%d image\n",
                         crop.width, crop.height, x0, y0, whole.width, whole.height);
            return 1;
        }
        for (int y = 0; y < crop.height; ++y)
            for (int x = 0; x < crop.width; ++x)
                for (int c = 0; c < 3; ++c) {
                    const float a = whole.rgb[3 * (size_t(y0 + y) * whole.width + x0 + x) + c];
                    const float b = crop.rgb[3 * (size_t(y) * crop.width + x) + c];
                    if (std::memcmp(&a, &b, sizeof a) != 0) {
                        std::fprintf(stderr,
                                     "crop pixel (%d, %d) channel %d is %.9g, the whole image's "
                                     "(%d, %d) is %.9g\n",
                                     x, y, c, b, x0 + x, y0 + y, a);
                        return 1;
                    }
                }
        std::printf("%dx%d crop at (%d, %d): every pixel equals the whole image's\n", crop.width,
                    crop.height, x0, y0);
        return 0;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
}
