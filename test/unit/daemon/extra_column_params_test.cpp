// ftidd has no extra log columns at run time: a parameter file whose model reads one
// (payload(grip), poly(grip,1)) is refused when loaded, naming the file, the column and the way
// out (`ftid compensate` offline). docs/effects.md, "payload(s)".
#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

#include "ftid/common/error.hpp"
#include "ftid/daemon/adapters.hpp"
#include "ftid/params/parameter_set.hpp"

namespace ftid::daemon {
namespace {

params::ParameterSet setFor(const std::string& model) {
  params::ParameterSet set;
  set.model = model;
  const effects::Model m = effects::Model::fromName(model);
  for (const auto& name : m.paramIndex().names()) set.params.push_back({name, name == "mass" ? 1.0 : 0.001, 0.0, ""});
  return set;
}

TEST(ExtraColumnParameters, FtiddRefusesAModelThatReadsALogColumn) {
  char tmpl[] = "/tmp/ftid-extra-column-XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  for (const std::string model : {"paper+payload(grip)", "paper+poly(grip,1)"}) {
    const std::string path = dir + "/p.yaml";
    params::writeParameterFile(path, setFor(model));
    try {
      (void)parameterFileFactory()(path);
      ADD_FAILURE() << model << " loaded";
    } catch (const ConfigError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(path), std::string::npos) << what;
      EXPECT_NE(what.find("'grip'"), std::string::npos) << what;
      EXPECT_NE(what.find("ftid compensate"), std::string::npos) << what;
    }
  }
  // A signal ftidd has (time, a joint angle) loads.
  const std::string ok = dir + "/ok.yaml";
  params::writeParameterFile(ok, setFor("paper+poly(t,1)+payload(q6)"));
  EXPECT_NO_THROW((void)parameterFileFactory()(ok));
  (void)std::system(("rm -rf '" + dir + "'").c_str());
}

}  // namespace
}  // namespace ftid::daemon
