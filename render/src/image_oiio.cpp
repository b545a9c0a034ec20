// The OpenImageIO module of image I/O (image_oiio.h says why it is apart).
#include "image_oiio.h"

#include <OpenImageIO/imageio.h>

#include <memory>

namespace shadefit::internal {
namespace {

void* Open(const std::string& path, OiioSpec* spec, std::string* error) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    *error = OIIO::geterror();
    return nullptr;
  }
  spec->width = in->spec().width;
  spec->height = in->spec().height;
  spec->channels = in->spec().nchannels;
  spec->format_name = in->format_name();
  spec->pixel_type = in->spec().format.c_str();
  spec->is_float = in->spec().format.is_floating_point();
  return in.release();
}

bool Read(void* handle, float* pixels, std::string* error) {
  auto* in = static_cast<OIIO::ImageInput*>(handle);
  if (in->read_image(0, 0, 0, in->spec().nchannels, OIIO::TypeDesc::FLOAT, pixels)) return true;
  *error = in->geterror();
  return false;
}

void StringAttributes(void* handle, std::map<std::string, std::string>* out) {
  out->clear();
  for (const auto& attr : static_cast<OIIO::ImageInput*>(handle)->spec().extra_attribs) {
    if (attr.type() == OIIO::TypeDesc::STRING) (*out)[attr.name().string()] = attr.get_string();
  }
}

void Close(void* handle) {
  std::unique_ptr<OIIO::ImageInput> in(static_cast<OIIO::ImageInput*>(handle));
  in->close();
}

OiioWriteStatus Write(const OiioWrite& w, std::string* error) {
  const OIIO::TypeDesc type = w.uint8 ? OIIO::TypeDesc::UINT8 : OIIO::TypeDesc::FLOAT;
  OIIO::ImageSpec spec(w.width, w.height, w.channels, type);
  if (!w.channel_names.empty()) spec.channelnames = w.channel_names;
  if (w.alpha_channel >= 0) spec.alpha_channel = w.alpha_channel;
  for (const auto& [key, value] : w.attributes) spec.attribute(key, value);
  for (const auto& [key, value] : w.int_attributes) spec.attribute(key, value);
  auto out = OIIO::ImageOutput::create(w.final_path);  // Format from the final name.
  if (!out) {
    *error = OIIO::geterror();
    return OiioWriteStatus::kNoWriter;
  }
  if (!out->open(w.tmp_path, spec) || !out->write_image(type, w.pixels) || !out->close()) {
    *error = out->geterror();
    return OiioWriteStatus::kFailed;
  }
  return OiioWriteStatus::kOk;
}

constexpr OiioBackend kBackend{&Open, &Read, &StringAttributes, &Close, &Write};

}  // namespace
}  // namespace shadefit::internal

extern "C" const shadefit::internal::OiioBackend* ShadefitOiioBackend() {
  return &shadefit::internal::kBackend;
}
