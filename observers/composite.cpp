#include "observers/composite.h"

#include <map>
#include <stdexcept>

namespace sigmaheart::observers {

CompositeObserver::CompositeObserver(std::vector<std::unique_ptr<Observer>> parts)
    : parts_(std::move(parts)) {
  std::map<std::string, size_t> owner;
  for (size_t p = 0; p < parts_.size(); ++p) {
    if (!parts_[p]) throw std::invalid_argument("composite observer: part " + std::to_string(p) + " is null");
    offsets_.push_back(static_cast<int>(outputs_.size()));
    for (const auto& out : parts_[p]->outputs()) {
      auto [it, inserted] = owner.emplace(out.name, p);
      if (!inserted) {
        throw std::invalid_argument("composite observer: output '" + out.name +
                                    "' appears in part " + std::to_string(it->second) +
                                    " and in part " + std::to_string(p) +
                                    "; observation names must be unique");
      }
      outputs_.push_back(out);
    }
  }
}

model::Status CompositeObserver::observe(const model::Trajectory& trajectory,
                                         Eigen::Ref<Eigen::VectorXd> z) const {
  if (auto status = check_z_size("composite observer", z.size(), outputs_.size()); !status.ok()) {
    return status;
  }
  for (size_t p = 0; p < parts_.size(); ++p) {
    const Eigen::Index size = parts_[p]->size();
    auto status = parts_[p]->observe(trajectory, z.segment(offsets_[p], size));
    if (!status.ok()) {
      status.message = "observer part " + std::to_string(p) + ": " + status.message;
      return status;
    }
  }
  return model::Status::Ok();
}

std::unique_ptr<Observer> CompositeObserver::clone() const {
  std::vector<std::unique_ptr<Observer>> copies;
  for (const auto& p : parts_) copies.push_back(p->clone());
  return std::make_unique<CompositeObserver>(std::move(copies));
}

}  // namespace sigmaheart::observers
