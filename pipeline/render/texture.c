/* SPDX-License-Identifier: MIT */
#include "pipeline/render/texture.h"

#include <math.h>

#include "pipeline/render/vec3.h"

static int nearest(double x, int n)
{
    if (!(x > 0.0))
        return 0;
    if (x >= (double)(n - 1))
        return n - 1;
    return (int)x;
}

uint8_t tex_nearest_u8(const uint8_t *data, int width, int height, double u, double v)
{
    int i = nearest(u * width, width);
    int j = nearest((1.0 - v) * height, height);
    return data[(size_t)j * (size_t)width + (size_t)i];
}
