/* SPDX-License-Identifier: MIT */
/*
 * A HID sensor hub with one 3-D gyroscope, made through /dev/uhid, so the kernel's
 * hid-sensor-hub + hid-sensor-gyro-3d drivers give the VM a real IIO gyro
 * (iio:deviceN named "gyro_3d"). Answers the drivers' feature GET/SET requests
 * and sends input reports at 100 Hz with a fixed rate of turn: x 10, y -20,
 * z 30 deg/s. Runs until killed or for the seconds given as argv[1].
 */
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include <linux/input.h>
#include <linux/uhid.h>

/* Sensor page 0x20: an application collection holding one physical Gyrometer 3D collection. */
static const uint8_t descriptor[] = {
    0x05, 0x20,                   /* Usage Page (Sensor) */
    0x09, 0x01,                   /* Usage (Sensor) */
    0xa1, 0x01,                   /* Collection (Application) */
    0x09, 0x76,                   /*   Usage (Gyrometer 3D) */
    0xa1, 0x00,                   /*   Collection (Physical) */
    0x85, 0x01,                   /*     Report ID (1) */
    0x0a, 0x0e, 0x03,             /*     Usage (Report Interval), ms */
    0x15, 0x00, 0x27, 0xff, 0xff, 0xff, 0x7f, 0x75, 0x20, 0x95, 0x01, 0xb1, 0x02,
    0x0a, 0x16, 0x03,             /*     Usage (Reporting State) */
    0x15, 0x00, 0x25, 0x05, 0x75, 0x08, 0x95, 0x01, 0xb1, 0x02,
    0x0a, 0x19, 0x03,             /*     Usage (Power State) */
    0x15, 0x00, 0x25, 0x05, 0x75, 0x08, 0x95, 0x01, 0xb1, 0x02,
    0x0a, 0x0f, 0x03,             /*     Usage (Sensitivity Absolute) */
    0x15, 0x00, 0x26, 0xff, 0x7f, 0x75, 0x10, 0x95, 0x01, 0xb1, 0x02,
    /* one input field per axis: the drivers look fields up by their first usage */
    0x0a, 0x57, 0x04, 0x16, 0x00, 0x80, 0x26, 0xff, 0x7f, 0x75, 0x10, 0x95, 0x01, 0x81, 0x02,
    0x0a, 0x58, 0x04, 0x16, 0x00, 0x80, 0x26, 0xff, 0x7f, 0x75, 0x10, 0x95, 0x01, 0x81, 0x02,
    0x0a, 0x59, 0x04, 0x16, 0x00, 0x80, 0x26, 0xff, 0x7f, 0x75, 0x10, 0x95, 0x01, 0x81, 0x02,
    0xc0,                         /*   End Collection */
    0xc0,                         /* End Collection */
};

/* Feature report 1: id, interval (u32 ms), reporting state, power state, sensitivity (u16). */
static uint8_t feature[9] = { 1, 10, 0, 0, 0, 2, 1, 0, 0 };
static const int16_t rate_dps[3] = { 10, -20, 30 };

static int send_event(int fd, const struct uhid_event *ev)
{
    ssize_t n = write(fd, ev, sizeof(*ev));
    return n == (ssize_t)sizeof(*ev) ? 0 : -1;
}

static void input_report(uint8_t *buf)
{
    buf[0] = 1;
    for (int a = 0; a < 3; a++) {
        buf[1 + 2 * a] = (uint8_t)((uint16_t)rate_dps[a] & 0xff);
        buf[2 + 2 * a] = (uint8_t)((uint16_t)rate_dps[a] >> 8);
    }
}

static int create(int fd)
{
    struct uhid_event ev;
    memset(&ev, 0, sizeof(ev));
    ev.type = UHID_CREATE2;
    snprintf((char *)ev.u.create2.name, sizeof(ev.u.create2.name), "sunprobe uhid sensor hub");
    memcpy(ev.u.create2.rd_data, descriptor, sizeof(descriptor));
    ev.u.create2.rd_size = sizeof(descriptor);
    ev.u.create2.bus = BUS_USB;
    ev.u.create2.vendor = 0x1d6b;
    ev.u.create2.product = 0x5350;
    return send_event(fd, &ev);
}

static void answer_get(int fd, const struct uhid_get_report_req *req)
{
    struct uhid_event ev;
    memset(&ev, 0, sizeof(ev));
    ev.type = UHID_GET_REPORT_REPLY;
    ev.u.get_report_reply.id = req->id;
    if (req->rnum != 1) {
        ev.u.get_report_reply.err = EIO;
    } else if (req->rtype == UHID_FEATURE_REPORT) {
        memcpy(ev.u.get_report_reply.data, feature, sizeof(feature));
        ev.u.get_report_reply.size = sizeof(feature);
    } else {
        input_report(ev.u.get_report_reply.data);
        ev.u.get_report_reply.size = 7;
    }
    send_event(fd, &ev);
}

static void answer_set(int fd, const struct uhid_set_report_req *req)
{
    struct uhid_event ev;
    memset(&ev, 0, sizeof(ev));
    ev.type = UHID_SET_REPORT_REPLY;
    ev.u.set_report_reply.id = req->id;
    if (req->rnum == 1 && req->rtype == UHID_FEATURE_REPORT && req->size >= 2) {
        size_t n = req->size < sizeof(feature) ? req->size : sizeof(feature);
        memcpy(feature, req->data, n);
        feature[0] = 1;
    } else {
        ev.u.set_report_reply.err = EIO;
    }
    send_event(fd, &ev);
}

static int64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static void handle(int fd)
{
    struct uhid_event ev;
    if (read(fd, &ev, sizeof(ev)) <= 0)
        return;
    if (ev.type == UHID_GET_REPORT)
        answer_get(fd, &ev.u.get_report);
    else if (ev.type == UHID_SET_REPORT)
        answer_set(fd, &ev.u.set_report);
}

int main(int argc, char **argv)
{
    double seconds = argc > 1 ? atof(argv[1]) : 1e9;
    int fd = open("/dev/uhid", O_RDWR | O_CLOEXEC);
    if (fd < 0 || create(fd) < 0) {
        fprintf(stderr, "uhid_gyro: %s\n", strerror(errno));
        return 1;
    }
    int64_t start = now_ns(), next = start;
    while ((double)(now_ns() - start) * 1e-9 < seconds) {
        struct pollfd p = { .fd = fd, .events = POLLIN };
        int64_t wait_ms = (next - now_ns()) / 1000000;
        if (poll(&p, 1, wait_ms > 0 ? (int)wait_ms : 0) > 0)
            handle(fd);
        if (now_ns() < next)
            continue;
        next += 10000000; /* 100 Hz */
        struct uhid_event ev;
        memset(&ev, 0, sizeof(ev));
        ev.type = UHID_INPUT2;
        input_report(ev.u.input2.data);
        ev.u.input2.size = 7;
        send_event(fd, &ev);
    }
    struct uhid_event ev;
    memset(&ev, 0, sizeof(ev));
    ev.type = UHID_DESTROY;
    send_event(fd, &ev);
    close(fd);
    return 0;
}
