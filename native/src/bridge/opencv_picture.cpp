/* OpenCV side of the picture module: decoding PNG/JPEG/EXR into float RGBA, GrabCut mask
 * proposals, inpainting of the background behind vegetation, exact distance transforms for
 * the mattes, and cv::remap (the benchmark's peer). Everything is behind extern "C"
 * functions that catch every exception; OpenCV types never leave this file. */
#include "opencv_picture_bridge.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

namespace {

/* OpenCV 4.6 refuses OpenEXR unless OPENCV_IO_ENABLE_OPENEXR is set before the codec is
 * first used (it reads the variable once). Set it unless the host already chose. */
void enable_exr_once() {
    static std::once_flag once;
    std::call_once(once, [] {
        if (std::getenv("OPENCV_IO_ENABLE_OPENEXR") == nullptr)
            setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 0);
    });
}

tsk_status opencv_failed(const char* where, const char* what) {
    return tsk_error(TSK_ERR_INTERNAL, "OpenCV failed in %s: %s", where, what);
}

} // namespace

extern "C" tsk_status tsk_cvp_decode(const char* path, int width, int height, float* rgba) {
    const char* name = path;
    try {
        enable_exr_once();
        /* imread, not imdecode: OpenCV decodes EXR from memory through a temporary file */
        cv::Mat img;
        try {
            img = cv::imread(path, cv::IMREAD_UNCHANGED);
        } catch (const cv::Exception& e) {
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' could not be decoded: %s", name,
                                 e.what());
        }
        if (img.empty())
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' could not be decoded (truncated or corrupt image?)", name);
        if (img.cols != width || img.rows != height)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' decodes to %dx%d but its header says %dx%d", name, img.cols,
                                 img.rows, width, height);
        const int ch = img.channels(), depth = img.depth();
        if (ch < 1 || ch > 4)
            return tsk_error_arg(TSK_ERR_FORMAT, "path", "'%s' has %d channels (1-4 expected)",
                                 name, ch);
        double scale = 1.0;
        if (depth == CV_8U) scale = 1.0 / 255.0;
        else if (depth == CV_16U) scale = 1.0 / 65535.0;
        else if (depth != CV_32F)
            return tsk_error_arg(TSK_ERR_FORMAT, "path",
                                 "'%s' has an unsupported sample type (8/16-bit or float expected)",
                                 name);
        cv::Mat f;
        img.convertTo(f, CV_MAKETYPE(CV_32F, ch), scale);
        cv::Mat out(height, width, CV_32FC4, rgba);
        switch (ch) {
            case 1:
                cv::cvtColor(f, out, cv::COLOR_GRAY2RGBA);
                break;
            case 2: {
                /* grey + alpha: OpenCV 4.6 has no conversion, copy by hand */
                for (int y = 0; y < height; ++y) {
                    const float* s = f.ptr<float>(y);
                    float* d = out.ptr<float>(y);
                    for (int x = 0; x < width; ++x) {
                        d[4 * x + 0] = d[4 * x + 1] = d[4 * x + 2] = s[2 * x];
                        d[4 * x + 3] = s[2 * x + 1];
                    }
                }
                break;
            }
            case 3:
                cv::cvtColor(f, out, cv::COLOR_BGR2RGBA);
                break;
            case 4:
                cv::cvtColor(f, out, cv::COLOR_BGRA2RGBA);
                break;
        }
        if (out.data != (uchar*)rgba) return opencv_failed("decode", "output was reallocated");
        /* cvtColor(GRAY/BGR -> RGBA) sets alpha to 1.0 for float images */
        return TSK_OK;
    } catch (const std::exception& e) { return opencv_failed("decode", e.what()); } catch (...) {
        return opencv_failed("decode", "unknown exception");
    }
}

extern "C" tsk_status tsk_cvp_grabcut(const float* rgba, int width, int height, int rx, int ry,
                                      int rw, int rh, int iterations, const uint8_t* strokes,
                                      uint8_t* mask) {
    try {
        cv::Mat src(height, width, CV_32FC4, const_cast<float*>(rgba));
        cv::Mat bgr;
        cv::cvtColor(src, bgr, cv::COLOR_RGBA2BGR);
        cv::Mat bgr8;
        bgr.convertTo(bgr8, CV_8UC3, 255.0); /* saturates: clamps to [0, 255] */
        cv::Mat labels(height, width, CV_8U, cv::Scalar(cv::GC_BGD));
        const cv::Rect rect(rx, ry, rw, rh);
        labels(rect).setTo(cv::GC_PR_FGD);
        int fg = 0;
        for (int i = 0; i < width * height; ++i) {
            uint8_t* l = labels.data + i;
            if (strokes != nullptr) {
                if (strokes[i] == 1) *l = cv::GC_FGD;
                else if (strokes[i] == 2) *l = cv::GC_BGD;
            }
            fg += (*l == cv::GC_FGD || *l == cv::GC_PR_FGD);
        }
        if (fg == 0 || fg == width * height)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "rect",
                                 "GrabCut needs both background and foreground pixels");
        /* GrabCut seeds k-means from the thread's cv::RNG: fix it for determinism */
        cv::RNG& rng = cv::theRNG();
        const uint64 saved = rng.state;
        rng.state = 0x7455535355434bull;
        cv::Mat bgd, fgd;
        try {
            cv::grabCut(bgr8, labels, rect, bgd, fgd, iterations, cv::GC_INIT_WITH_MASK);
        } catch (...) {
            rng.state = saved;
            throw;
        }
        rng.state = saved;
        for (int i = 0; i < width * height; ++i) {
            const uint8_t l = labels.data[i];
            mask[i] = (l == cv::GC_FGD || l == cv::GC_PR_FGD) ? 255 : 0;
        }
        return TSK_OK;
    } catch (const std::exception& e) { return opencv_failed("grabCut", e.what()); } catch (...) {
        return opencv_failed("grabCut", "unknown exception");
    }
}

extern "C" tsk_status tsk_cvp_inpaint(float* rgba, int width, int height, const uint8_t* region,
                                      float radius, int method, int channels) {
    try {
        cv::Mat img(height, width, CV_32FC4, rgba);
        cv::Mat m(height, width, CV_8U, const_cast<uint8_t*>(region));
        std::vector<cv::Mat> planes;
        cv::split(img, planes);
        const int flags = method == 1 ? cv::INPAINT_NS : cv::INPAINT_TELEA;
        cv::Mat keep = m == 0;
        /* OpenCV before 4.10 fills a region that touches the image's top or left edge wrongly
         * (OpenCV issue 25389), and 4.10 saturates single-pixel holes in its corners (28648):
         * inpainted inside a frame of one pixel that is itself to be filled, no pixel of the
         * picture is on an edge. */
        cv::Mat framed_m;
        cv::copyMakeBorder(m, framed_m, 1, 1, 1, 1, cv::BORDER_CONSTANT, cv::Scalar(255));
        const cv::Rect inside(1, 1, width, height);
        for (int c = 0; c < channels && c < 4; ++c) {
            /* OpenCV's Telea adds terms of order 1 to a sample, as if samples were integers
             * (before 4.10, 0.5 for rounding), a large error for values in 0..1: each
             * channel is scaled up to 2^24 first, where such terms fall below a float's
             * precision, and back after. */
            cv::Mat& plane = planes[(size_t)c];
            double lo = 0, hi = 0;
            cv::minMaxLoc(plane, &lo, &hi);
            const double range = std::max(1.0, std::max(std::fabs(lo), std::fabs(hi)));
            const double scale = 16777216.0 / range;
            cv::Mat up, framed, filled, back;
            plane.convertTo(up, CV_32F, scale);
            cv::copyMakeBorder(up, framed, 1, 1, 1, 1, cv::BORDER_REPLICATE);
            cv::inpaint(framed, framed_m, filled, (double)radius, flags);
            filled(inside).convertTo(back, CV_32F, 1.0 / scale);
            plane.copyTo(back, keep); /* pixels outside the region keep their exact values */
            plane = back;
        }
        cv::Mat merged;
        cv::merge(planes, merged);
        merged.copyTo(img);
        if (img.data != (uchar*)rgba) return opencv_failed("inpaint", "output was reallocated");
        return TSK_OK;
    } catch (const std::exception& e) { return opencv_failed("inpaint", e.what()); } catch (...) {
        return opencv_failed("inpaint", "unknown exception");
    }
}

extern "C" tsk_status tsk_cvp_distances(const uint8_t* mask, int width, int height, float* inside,
                                        float* outside) {
    try {
        cv::Mat m(height, width, CV_8U, const_cast<uint8_t*>(mask));
        cv::Mat in_bin = m != 0, out_bin = m == 0;
        cv::Mat din(height, width, CV_32F, inside), dout(height, width, CV_32F, outside);
        cv::distanceTransform(in_bin, din, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
        cv::distanceTransform(out_bin, dout, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
        if (din.data != (uchar*)inside || dout.data != (uchar*)outside)
            return opencv_failed("distanceTransform", "output was reallocated");
        return TSK_OK;
    } catch (const std::exception& e) {
        return opencv_failed("distanceTransform", e.what());
    } catch (...) { return opencv_failed("distanceTransform", "unknown exception"); }
}

extern "C" tsk_status tsk_cvp_remap(const float* src, int width, int height, const float* map_x,
                                    const float* map_y, float* dst, int threads) {
    try {
        const int saved = cv::getNumThreads();
        cv::setNumThreads(threads);
        cv::Mat s(height, width, CV_32FC4, const_cast<float*>(src));
        cv::Mat mx(height, width, CV_32F, const_cast<float*>(map_x));
        cv::Mat my(height, width, CV_32F, const_cast<float*>(map_y));
        cv::Mat d(height, width, CV_32FC4, dst);
        cv::remap(s, d, mx, my, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
        cv::setNumThreads(saved);
        if (d.data != (uchar*)dst) return opencv_failed("remap", "output was reallocated");
        return TSK_OK;
    } catch (const std::exception& e) { return opencv_failed("remap", e.what()); } catch (...) {
        return opencv_failed("remap", "unknown exception");
    }
}

extern "C" tsk_status tsk_cvp_encode(const char* path, const float* rgba, int width, int height,
                                     int channels, int bits) {
    try {
        enable_exr_once();
        cv::Mat src(height, width, CV_32FC4, const_cast<float*>(rgba));
        cv::Mat f;
        if (channels == 1) {
            cv::extractChannel(src, f, 0);
        } else if (channels == 3) {
            cv::cvtColor(src, f, cv::COLOR_RGBA2BGR);
        } else if (channels == 4) {
            cv::cvtColor(src, f, cv::COLOR_RGBA2BGRA);
        } else {
            return tsk_error_arg(TSK_ERR_ARGUMENT, "channels", "must be 1, 3 or 4, got %d",
                                 channels);
        }
        cv::Mat out;
        if (bits == 8) f.convertTo(out, CV_MAKETYPE(CV_8U, channels), 255.0);
        else if (bits == 16) f.convertTo(out, CV_MAKETYPE(CV_16U, channels), 65535.0);
        else if (bits == 32) out = f;
        else return tsk_error_arg(TSK_ERR_ARGUMENT, "bits", "must be 8, 16 or 32, got %d", bits);
        if (!cv::imwrite(path, out))
            return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s'", path);
        return TSK_OK;
    } catch (const std::exception& e) {
        return tsk_error_arg(TSK_ERR_IO, "path", "cannot write '%s': %s", path, e.what());
    } catch (...) { return opencv_failed("imwrite", "unknown exception"); }
}

extern "C" tsk_status tsk_cvp_write_exr(const char* path, const float* rgba, int width,
                                        int height) {
    try {
        enable_exr_once();
        cv::Mat src(height, width, CV_32FC4, const_cast<float*>(rgba));
        cv::Mat bgra;
        cv::cvtColor(src, bgra, cv::COLOR_RGBA2BGRA);
        const std::vector<int> params = {cv::IMWRITE_EXR_TYPE, cv::IMWRITE_EXR_TYPE_FLOAT,
                                         cv::IMWRITE_EXR_COMPRESSION,
                                         cv::IMWRITE_EXR_COMPRESSION_ZIP};
        /* imwrite, not imencode: OpenCV encodes EXR to memory through a temporary file of
         * its own in /tmp, which it leaves behind when the write fails */
        if (!cv::imwrite(path, bgra, params))
            return tsk_error_arg(TSK_ERR_IO, "path", "OpenCV could not write '%s'", path);
        return TSK_OK;
    } catch (const std::exception& e) {
        return tsk_error_arg(TSK_ERR_IO, "path", "OpenCV could not write '%s': %s", path, e.what());
    } catch (...) { return opencv_failed("imwrite", "unknown exception"); }
}
