/* OpenCV side of the capture module: depth image decoding/encoding, mask morphology,
 * outer contours (cv::findContours) and polygon drawing. Everything is behind extern "C"
 * functions that catch every exception; OpenCV types never leave this file. */
#include "opencv_capture_bridge.h"

#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace {

/* OpenCV 4.6 refuses OpenEXR unless OPENCV_IO_ENABLE_OPENEXR is set before the codec is
 * first used (it reads the variable once). Set it, unless the host set it already (then
 * the host's choice stands and an EXR may fail with a clear message). */
void enable_exr_once() {
    static std::once_flag once;
    std::call_once(once, [] {
        if (std::getenv("OPENCV_IO_ENABLE_OPENEXR") == nullptr)
            setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);
    });
}

tsk_status from_exception(const char* what, const char* where) {
    return tsk_error(TSK_ERR_INTERNAL, "OpenCV failed in %s: %s", where, what);
}

bool valid_image(int w, int h) { return w > 0 && h > 0 && (long long)w * h < (1ll << 31); }

} // namespace

extern "C" tsk_status tsk_cvb_read_depth(const char* path, int* width, int* height,
                                         tsk_cvb_depth_type* type, void** data) {
    *data = nullptr;
    try {
        enable_exr_once();
        cv::Mat img = cv::imread(path, cv::IMREAD_UNCHANGED);
        if (img.empty())
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' could not be decoded (truncated or corrupt image?)", path);
        const int depth = img.depth(), ch = img.channels();
        if (depth == CV_32F && ch > 1) {
            /* accept a grey EXR stored as RGB(A) only if its colour channels are equal */
            std::vector<cv::Mat> planes;
            cv::split(img, planes);
            for (int c = 1; c < ch && c < 3; ++c) {
                cv::Mat diff;
                cv::compare(planes[0], planes[c], diff, cv::CMP_NE);
                /* NaN != NaN: treat as equal here, NaN is rejected later */
                cv::Mat nan0, nanc;
                cv::compare(planes[0], planes[0], nan0, cv::CMP_NE);
                cv::compare(planes[c], planes[c], nanc, cv::CMP_NE);
                diff &= ~(nan0 & nanc);
                if (cv::countNonZero(diff) > 0)
                    return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                         "'%s' is a colour OpenEXR; depth must be one channel "
                                         "of metres",
                                         path);
            }
            img = planes[0];
        }
        if (img.channels() != 1)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' has %d channels; depth must be a single-channel image "
                                 "(16-bit PNG in mm or float OpenEXR in m)",
                                 path, img.channels());
        if (img.depth() != CV_16U && img.depth() != CV_32F)
            return tsk_error_arg(
                TSK_ERR_FORMAT, "path",
                "'%s' is %s; depth must be 16-bit PNG in mm or 32-bit float "
                "OpenEXR in m",
                path, img.depth() == CV_8U ? "an 8-bit image" : "of an unsupported type");
        if (!valid_image(img.cols, img.rows))
            return tsk_error_arg(TSK_ERR_LIMIT, "path", "'%s' has an invalid size", path);
        const size_t elem = img.depth() == CV_16U ? 2 : 4;
        const size_t row = (size_t)img.cols * elem;
        unsigned char* out = (unsigned char*)tsk_alloc(row * (size_t)img.rows, "depth image");
        if (out == nullptr) return TSK_ERR_MEMORY;
        for (int y = 0; y < img.rows; ++y) std::memcpy(out + row * (size_t)y, img.ptr(y), row);
        *width = img.cols;
        *height = img.rows;
        *type = img.depth() == CV_16U ? TSK_CVB_U16 : TSK_CVB_F32;
        *data = out;
        return TSK_OK;
    } catch (const std::exception& e) {
        tsk_free(*data);
        *data = nullptr;
        return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' could not be decoded: %s", path,
                             e.what());
    } catch (...) {
        return tsk_error(TSK_ERR_INTERNAL, "unknown exception while decoding '%s'", path);
    }
}

static tsk_status write_image(const char* path, const cv::Mat& img,
                              const std::vector<int>& params) {
    try {
        enable_exr_once();
        if (!cv::imwrite(path, img, params))
            return tsk_error_arg(TSK_ERR_IO, "path", "'%s' could not be written", path);
        return TSK_OK;
    } catch (const std::exception& e) {
        return tsk_error_arg(TSK_ERR_IO, "path", "'%s' could not be written: %s", path, e.what());
    } catch (...) {
        return tsk_error(TSK_ERR_INTERNAL, "unknown exception while writing '%s'", path);
    }
}

extern "C" tsk_status tsk_cvb_write_png16(const char* path, const uint16_t* data, int width,
                                          int height) {
    if (!valid_image(width, height)) return tsk_error_arg(TSK_ERR_ARGUMENT, "size", "invalid");
    cv::Mat img(height, width, CV_16UC1, const_cast<uint16_t*>(data));
    return write_image(path, img, {cv::IMWRITE_PNG_COMPRESSION, 1});
}

extern "C" tsk_status tsk_cvb_write_exr(const char* path, const float* data, int width,
                                        int height) {
    if (!valid_image(width, height)) return tsk_error_arg(TSK_ERR_ARGUMENT, "size", "invalid");
    cv::Mat img(height, width, CV_32FC1, const_cast<float*>(data));
    return write_image(path, img, {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT});
}

extern "C" tsk_status tsk_cvb_write_png8(const char* path, const uint8_t* data, int width,
                                         int height, int channels) {
    if (!valid_image(width, height) || (channels != 1 && channels != 3))
        return tsk_error_arg(TSK_ERR_ARGUMENT, "size", "invalid");
    cv::Mat img(height, width, CV_8UC(channels), const_cast<uint8_t*>(data));
    return write_image(path, img, {});
}

extern "C" tsk_status tsk_cvb_morphology(uint8_t* mask, int width, int height, int close_radius,
                                         int open_radius) {
    try {
        cv::Mat m(height, width, CV_8UC1, mask);
        if (close_radius > 0) {
            cv::Mat k = cv::getStructuringElement(
                cv::MORPH_ELLIPSE, cv::Size(2 * close_radius + 1, 2 * close_radius + 1));
            cv::morphologyEx(m, m, cv::MORPH_CLOSE, k, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
        }
        if (open_radius > 0) {
            cv::Mat k = cv::getStructuringElement(
                cv::MORPH_ELLIPSE, cv::Size(2 * open_radius + 1, 2 * open_radius + 1));
            cv::morphologyEx(m, m, cv::MORPH_OPEN, k, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
        }
        return TSK_OK;
    } catch (const std::exception& e) {
        return from_exception(e.what(), "morphology");
    } catch (...) { return tsk_error(TSK_ERR_INTERNAL, "unknown exception in morphology"); }
}

extern "C" void tsk_cvb_contours_free(tsk_cvb_contours* c) {
    if (c == nullptr) return;
    tsk_free(c->start);
    tsk_free(c->xy);
    tsk_free(c->area);
    std::memset(c, 0, sizeof *c);
}

extern "C" tsk_status tsk_cvb_find_contours(const uint8_t* mask, int width, int height,
                                            double min_area, tsk_cvb_contours* out) {
    std::memset(out, 0, sizeof *out);
    try {
        cv::Mat m(height, width, CV_8UC1, const_cast<uint8_t*>(mask));
        std::vector<std::vector<cv::Point>> contours;
        cv::findContours(m, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
        std::vector<int> keep;
        std::vector<double> areas;
        size_t total = 0;
        for (size_t i = 0; i < contours.size(); ++i) {
            double a = cv::contourArea(contours[i]);
            if (a >= min_area && contours[i].size() >= 8) {
                keep.push_back((int)i);
                areas.push_back(a);
                total += contours[i].size();
            }
        }
        out->start = (int*)tsk_alloc((keep.size() + 1) * sizeof(int), "contours");
        out->xy = (int32_t*)tsk_alloc(2 * total * sizeof(int32_t), "contours");
        out->area = (double*)tsk_alloc(keep.size() * sizeof(double), "contours");
        if (!out->start || !out->xy || !out->area) {
            tsk_cvb_contours_free(out);
            return TSK_ERR_MEMORY;
        }
        size_t at = 0;
        for (size_t k = 0; k < keep.size(); ++k) {
            out->start[k] = (int)at;
            out->area[k] = areas[k];
            for (const cv::Point& p : contours[(size_t)keep[k]]) {
                out->xy[2 * at] = p.x;
                out->xy[2 * at + 1] = p.y;
                ++at;
            }
        }
        out->start[keep.size()] = (int)at;
        out->count = (int)keep.size();
        return TSK_OK;
    } catch (const std::exception& e) {
        tsk_cvb_contours_free(out);
        return from_exception(e.what(), "findContours");
    } catch (...) {
        tsk_cvb_contours_free(out);
        return tsk_error(TSK_ERR_INTERNAL, "unknown exception in findContours");
    }
}

static std::vector<cv::Point> to_points(const float* xy, int n) {
    std::vector<cv::Point> pts((size_t)n);
    for (int i = 0; i < n; ++i)
        pts[(size_t)i] = cv::Point(cvRound(xy[2 * i]), cvRound(xy[2 * i + 1]));
    return pts;
}

extern "C" tsk_status tsk_cvb_fill_poly(uint8_t* img, int width, int height, const float* xy, int n,
                                        uint8_t value) {
    try {
        if (n < 3) return TSK_OK;
        cv::Mat m(height, width, CV_8UC1, img);
        std::vector<std::vector<cv::Point>> polys{to_points(xy, n)};
        cv::fillPoly(m, polys, cv::Scalar(value), cv::LINE_8);
        return TSK_OK;
    } catch (const std::exception& e) { return from_exception(e.what(), "fillPoly"); } catch (...) {
        return tsk_error(TSK_ERR_INTERNAL, "unknown exception in fillPoly");
    }
}

extern "C" tsk_status tsk_cvb_polyline(uint8_t* img, int width, int height, const float* xy, int n,
                                       uint8_t value) {
    try {
        if (n < 2) return TSK_OK;
        cv::Mat m(height, width, CV_8UC1, img);
        std::vector<std::vector<cv::Point>> polys{to_points(xy, n)};
        cv::polylines(m, polys, false, cv::Scalar(value), 1, cv::LINE_8);
        return TSK_OK;
    } catch (const std::exception& e) {
        return from_exception(e.what(), "polylines");
    } catch (...) { return tsk_error(TSK_ERR_INTERNAL, "unknown exception in polylines"); }
}

extern "C" void tsk_cvb_set_threads(int threads) {
    static std::mutex mu;
    static int current = -1;
    std::lock_guard<std::mutex> lock(mu);
    if (threads == current) return;
    try {
        cv::setNumThreads(threads);
        current = threads;
    } catch (...) {}
}
