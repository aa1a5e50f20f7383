// cv_modules.cpp -- thread modules of test_online_change's conversions:
//   CV_V1   built against cv1: fb.count += 1 every run, and fixed values in every other variable
//   CV_V2   built against cv2: fb.count += 1 every run; first_count = fb.count in its first run; wrong
//           += 1 whenever it reads a converted scalar other than what v1 wrote (plain loads: no lock)
//   CV_V_NARROW built against cv_narrow: fb.count += 1 every run
#include <indurop/indurop.h>
#include <indurop/generated.h>

using namespace cv;

#if defined(CV_V2)
namespace {
bool first = true;
}
#endif

void run() {
#if defined(CV_V2)
    if (first) first_count = fb.count;
    first = false;
    if (wide != -1234 || f != 1.5 || i2f != -300.0f || nest[1].inner.a != 32000 || arr[2] != 30) wrong += 1;
#endif
    fb.count += 1;
#if defined(CV_V1)
    fb.mode = 5;
    wide = -1234;
    for (int i = 0; i < 3; ++i) arr[i] = 10 * (i + 1);
    narrow = 70000;
    f = 1.5f;
    i2f = -300;
    nest[0].inner.a = -7;
    nest[0].inner.b = 2.25f;
    nest[0].tag = 9;
    nest[1].inner.a = 32000;
    nest[1].inner.b = -0.5f;
    nest[1].tag = 200;
#endif
}
