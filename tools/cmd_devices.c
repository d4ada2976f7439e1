/* SPDX-License-Identifier: MIT */
/* `sunprobe devices`: cameras with their formats and sizes, IMUs with their channels and rates. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "sunprobe/sp_camera.h"
#include "sunprobe/sp_imu_device.h"

#define MAX_CAMERAS 32
#define MAX_MODES 256
#define MAX_IMUS 32

static void usage(FILE *out)
{
    size_t n = 0;
    const sp_camera_ops *const *cams = sp_camera_backends(&n);
    fprintf(out, "usage: sunprobe devices [--cameras] [--imus]\n\n"
                 "Lists the cameras (pixel formats, sizes, fastest rates) and IMUs (sensors, channels, rates)\n"
                 "this machine offers. Camera backends in this build:");
    for (size_t i = 0; i < n; i++)
        fprintf(out, " %s", cams[i]->name);
    fprintf(out, ".\nThe ids printed are what `sunprobe record --camera/--imu` accept.\n");
}

static void print_modes(const sp_camera_desc *d)
{
    sp_camera_mode *modes = calloc(MAX_MODES, sizeof(*modes));
    size_t n = 0;
    int err = modes ? sp_camera_modes(d, modes, MAX_MODES, &n) : -12;
    if (err < 0) {
        printf("    (formats unavailable: %s)\n", sp_strerror(err));
        free(modes);
        return;
    }
    enum sp_pixfmt current = SP_PIXFMT_NONE;
    for (size_t i = 0; i < n && i < MAX_MODES; i++) {
        if (modes[i].format != current) {
            current = modes[i].format;
            printf("%s    %-6s", i ? "\n" : "", sp_pixfmt_name(current));
        }
        printf(" %ux%u", modes[i].width, modes[i].height);
        if (modes[i].max_fps > 0)
            printf("@%g", modes[i].max_fps);
    }
    printf(n ? "\n" : "    (no format sunprobe can record)\n");
    free(modes);
}

static void list_cameras(void)
{
    sp_camera_desc cams[MAX_CAMERAS];
    size_t n = 0;
    sp_camera_enumerate(cams, MAX_CAMERAS, &n);
    printf("cameras: %zu\n", n);
    for (size_t i = 0; i < n && i < MAX_CAMERAS; i++) {
        printf("  [%s] %s: %s%s%s%s\n", cams[i].backend, cams[i].id, cams[i].name, cams[i].driver[0] ? " (" : "",
               cams[i].driver, cams[i].driver[0] ? ")" : "");
        print_modes(&cams[i]);
    }
}

static void list_imus(void)
{
    sp_imu_desc imus[MAX_IMUS];
    size_t n = 0;
    sp_imu_device_enumerate(imus, MAX_IMUS, &n);
    printf("imus: %zu\n", n);
    for (size_t i = 0; i < n && i < MAX_IMUS; i++) {
        const sp_imu_desc *d = &imus[i];
        printf("  [%s] %s: %s\n    sensors:", d->backend, d->id, d->name[0] ? d->name : "(unnamed)");
        for (int k = SP_IMU_GYRO; k <= SP_IMU_MAG; k++)
            if (d->sensors & SP_IMU_SENSOR_BIT(k))
                printf(" %s", sp_imu_sensor_name((enum sp_imu_sensor)k));
        printf("\n    channels: %s\n    rate: ", d->channels);
        if (d->rate_hz > 0)
            printf("%g Hz", d->rate_hz);
        else
            printf("unknown");
        if (d->rates[0])
            printf(" (available: %s)", d->rates);
        printf(", %s\n", d->buffered ? "buffered" : "polled");
    }
}

int sp_cmd_devices(int argc, char **argv)
{
    static const struct option opts[] = { { "help", no_argument, NULL, 'h' }, { "cameras", no_argument, NULL, 'c' },
                                          { "imus", no_argument, NULL, 'i' }, { 0 } };
    int c, cams = 0, imus = 0;
    while ((c = getopt_long(argc, argv, "hci", opts, NULL)) != -1) {
        if (c == 'h') {
            usage(stdout);
            return SP_EXIT_OK;
        }
        if (c == 'c')
            cams = 1;
        else if (c == 'i')
            imus = 1;
        else {
            usage(stderr);
            return SP_EXIT_USAGE;
        }
    }
    if (optind != argc) {
        usage(stderr);
        return SP_EXIT_USAGE;
    }
    if (!cams && !imus)
        cams = imus = 1;
    if (cams)
        list_cameras();
    if (imus)
        list_imus();
    return SP_EXIT_OK;
}
