/*
 * A stand-in for the kernel's CAN sockets, for test_trace.py: preloaded into can-utils'
 * canplayer (LD_PRELOAD) on a host without SocketCAN (no PF_CAN in the kernel, so canplayer
 * cannot even open its socket). It changes nothing of canplayer's own work: canplayer still
 * reads and parses the log file, keeps its timing and interface assignments, and builds one
 * `struct can_frame` per line; this file only takes the place of the socket those frames are
 * written to, and writes each of them as a text line to the file named by CANPLAYER_CAPTURE:
 *
 *     <interface> <ID>#<DATA>         e.g.  vcan0 605#4000100000000000
 *
 * Calls on other sockets and files go to the C library as usual.
 *
 * Build: gcc -O2 -shared -fPIC -o canplayer_shim.so canplayer_shim.c -ldl
 */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <fcntl.h>
#include <net/if.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <unistd.h>

#define FAMILY_CAN 29          /* PF_CAN */
#define REQUEST_IFINDEX 0x8933 /* SIOCGIFINDEX */
#define EXTENDED_FLAG 0x80000000u
#define REMOTE_FLAG 0x40000000u
#define MAX_SOCKETS 16
#define MAX_INTERFACES 16

/* The layout of the kernel's struct can_frame (linux/can.h). */
struct frame {
    uint32_t id;
    uint8_t length;
    uint8_t padding[3];
    uint8_t data[8];
};

static int sockets[MAX_SOCKETS];
static int socket_count;
static char interfaces[MAX_INTERFACES][IF_NAMESIZE];
static int interface_count;

static int is_can_socket(int fd)
{
    for (int i = 0; i < socket_count; i++) {
        if (sockets[i] == fd) {
            return 1;
        }
    }
    return 0;
}

/* Interface numbers are handed out by name, from 1, as the kernel would. */
static int interface_index(const char *name)
{
    for (int i = 0; i < interface_count; i++) {
        if (strncmp(interfaces[i], name, IF_NAMESIZE) == 0) {
            return i + 1;
        }
    }
    if (interface_count == MAX_INTERFACES) {
        return 0;
    }
    snprintf(interfaces[interface_count], IF_NAMESIZE, "%.*s", IF_NAMESIZE - 1, name);
    return ++interface_count;
}

static const char *interface_name(int index)
{
    return index >= 1 && index <= interface_count ? interfaces[index - 1] : "?";
}

static ssize_t capture(int index, const void *buffer, size_t length)
{
    if (length < sizeof(struct frame)) {
        return -1;
    }
    struct frame frame;
    memcpy(&frame, buffer, sizeof frame);
    const char *path = getenv("CANPLAYER_CAPTURE");
    FILE *out = fopen(path ? path : "/dev/null", "a");
    if (out == NULL) {
        return -1;
    }
    if (frame.id & EXTENDED_FLAG) {
        fprintf(out, "%s %08X#", interface_name(index), frame.id & 0x1FFFFFFFu);
    } else {
        fprintf(out, "%s %03X#", interface_name(index), frame.id & 0x7FFu);
    }
    if (frame.id & REMOTE_FLAG) {
        fprintf(out, "R%u", frame.length);
    } else {
        for (unsigned i = 0; i < frame.length && i < 8; i++) {
            fprintf(out, "%02X", frame.data[i]);
        }
    }
    fputc('\n', out);
    fclose(out);
    return (ssize_t)length;
}

int socket(int domain, int type, int protocol)
{
    static int (*real)(int, int, int);
    if (domain == FAMILY_CAN) {
        int fd = open("/dev/null", O_RDWR);
        if (fd >= 0 && socket_count < MAX_SOCKETS) {
            sockets[socket_count++] = fd;
        }
        return fd;
    }
    if (!real) {
        real = (int (*)(int, int, int))dlsym(RTLD_NEXT, "socket");
    }
    return real(domain, type, protocol);
}

int setsockopt(int fd, int level, int name, const void *value, socklen_t length)
{
    static int (*real)(int, int, int, const void *, socklen_t);
    if (is_can_socket(fd)) {
        return 0;
    }
    if (!real) {
        real = (int (*)(int, int, int, const void *, socklen_t))dlsym(RTLD_NEXT, "setsockopt");
    }
    return real(fd, level, name, value, length);
}

int bind(int fd, const struct sockaddr *address, socklen_t length)
{
    static int (*real)(int, const struct sockaddr *, socklen_t);
    if (is_can_socket(fd)) {
        return 0;
    }
    if (!real) {
        real = (int (*)(int, const struct sockaddr *, socklen_t))dlsym(RTLD_NEXT, "bind");
    }
    return real(fd, address, length);
}

int ioctl(int fd, unsigned long request, ...)
{
    static int (*real)(int, unsigned long, void *);
    va_list arguments;
    va_start(arguments, request);
    void *argument = va_arg(arguments, void *);
    va_end(arguments);
    if (is_can_socket(fd) && request == REQUEST_IFINDEX) {
        struct ifreq *interface = argument;
        interface->ifr_ifindex = interface_index(interface->ifr_name);
        return interface->ifr_ifindex ? 0 : -1;
    }
    if (!real) {
        real = (int (*)(int, unsigned long, void *))dlsym(RTLD_NEXT, "ioctl");
    }
    return real(fd, request, argument);
}

ssize_t sendto(int fd, const void *buffer, size_t length, int flags, const struct sockaddr *address,
               socklen_t address_length)
{
    static ssize_t (*real)(int, const void *, size_t, int, const struct sockaddr *, socklen_t);
    if (is_can_socket(fd)) {
        int index = 0;
        if (address != NULL && address_length >= 8) {
            memcpy(&index, (const char *)address + 4, sizeof index); /* sockaddr_can.can_ifindex */
        }
        return capture(index, buffer, length);
    }
    if (!real) {
        real = (ssize_t (*)(int, const void *, size_t, int, const struct sockaddr *, socklen_t))dlsym(
            RTLD_NEXT, "sendto");
    }
    return real(fd, buffer, length, flags, address, address_length);
}
