// mctstereo: dense stereo matching on the (modified) census transform. Umbrella header.
#pragma once

#include "mctstereo/depth.hpp"
#include "mctstereo/image.hpp"
#include "mctstereo/matcher.hpp"
#include "mctstereo/metrics.hpp"
#include "mctstereo/params.hpp"
#include "mctstereo/pfm.hpp"
#include "mctstereo/version.hpp"
