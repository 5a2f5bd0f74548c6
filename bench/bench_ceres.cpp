#include "bench/bench_ceres.h"

#include <algorithm>
#include <map>
#include <vector>

#include <ceres/ceres.h>
#include <ceres/version.h>
#include <fmt/format.h>

#include "core/error.h"

namespace rig::bench {

std::string ceresLinearSolverName(CeresLinearSolver solver)
{
    return solver == CeresLinearSolver::denseQr ? "DENSE_QR" : "DENSE_NORMAL_CHOLESKY";
}

std::string ceresVersion() { return CERES_VERSION_STRING; }

namespace {

// Our residuals and analytic Jacobian, handed to Ceres as one residual block over one parameter block.
class ApproximationCost final : public ceres::CostFunction {
public:
    explicit ApproximationCost(ResidualWorkspace& workspace) : workspace_(workspace)
    {
        const ResidualStructure& s = workspace.structure();
        set_num_residuals(s.rows());
        mutable_parameter_block_sizes()->push_back(s.columnCount());
        jacobian_.resize(s.rows(), s.columnCount());
        r_.resize(s.rows());
    }

    bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override
    {
        const int n = workspace_.structure().columnCount();
        const int m = workspace_.structure().rows();
        const std::span<const double> x(parameters[0], static_cast<std::size_t>(n));
        Eigen::Map<Eigen::VectorXd> r(residuals, m);
        if (jacobians == nullptr || jacobians[0] == nullptr) {
            workspace_.residuals(x, r);
            return r.allFinite();
        }
        workspace_.jacobian(x, JacobianMethod::analytic, 1e-6, false, r_, jacobian_);
        r = r_;
        // Ceres wants the Jacobian row-major.
        Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[0], m, n) =
            jacobian_;
        return r_.allFinite() && jacobian_.allFinite();
    }

private:
    ResidualWorkspace& workspace_;
    mutable Eigen::MatrixXd jacobian_;
    mutable Eigen::VectorXd r_;
};

// The problem for one set of active outputs, built once and solved frame after frame.
struct CeresProblem {
    CeresProblem(const Approximation& approximation, std::vector<int> outputs)
        : structure(approximation, allColumns(approximation), std::move(outputs)),
          workspace(structure),
          cost(workspace),
          x(approximation.parameters.size())
    {
        workspace.holdParameters(approximation.defaults());  // every parameter is a column: only F_k(0) is held
        ceres::Problem::Options options;
        options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
        problem = std::make_unique<ceres::Problem>(options);
        problem->AddResidualBlock(&cost, nullptr, x.data());
        for (std::size_t p = 0; p < approximation.parameters.size(); ++p) {
            const RigParameter& param = approximation.parameters[p].parameter;
            if (!param.limited) continue;
            problem->SetParameterLowerBound(x.data(), static_cast<int>(p), param.min);
            problem->SetParameterUpperBound(x.data(), static_cast<int>(p), param.max);
        }
    }
    static std::vector<int> allColumns(const Approximation& approximation)
    {
        std::vector<int> columns(approximation.parameters.size());
        for (std::size_t p = 0; p < columns.size(); ++p) columns[p] = static_cast<int>(p);
        return columns;
    }

    ResidualStructure structure;
    ResidualWorkspace workspace;
    ApproximationCost cost;
    std::vector<double> x;
    std::unique_ptr<ceres::Problem> problem;
};

}  // namespace

struct CeresInverter::Impl {
    const Approximation& approximation;
    SolverOptions options;
    ceres::Solver::Options ceresOptions;
    std::map<std::vector<int>, std::unique_ptr<CeresProblem>> problems;
    std::vector<PreparedTarget> prepared;
};

CeresInverter::CeresInverter(const Approximation& approximation, const SolverOptions& options,
                             CeresLinearSolver linearSolver, bool ceresTolerances)
    : impl_(std::make_unique<Impl>(Impl{approximation, options, {}, {}, {}}))
{
    ceres::Solver::Options& o = impl_->ceresOptions;
    o.minimizer_type = ceres::TRUST_REGION;
    o.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
    o.linear_solver_type = linearSolver == CeresLinearSolver::denseQr ? ceres::DENSE_QR : ceres::DENSE_NORMAL_CHOLESKY;
    o.max_num_iterations = options.maxIterations;
    if (!ceresTolerances) {
        o.function_tolerance = options.functionTolerance;
        o.parameter_tolerance = options.parameterTolerance;
        o.gradient_tolerance = options.gradientTolerance;
    }
    o.num_threads = 1;
    o.logging_type = ceres::SILENT;
    o.minimizer_progress_to_stdout = false;
    std::string why;
    if (!o.IsValid(&why)) throw internalError(fmt::format("Ceres options: {}", why));
}

CeresInverter::~CeresInverter() = default;

CeresSolve CeresInverter::solve(std::span<const JointTarget> targets, std::span<double> values)
{
    Impl& impl = *impl_;
    const auto& outputs = impl.approximation.outputs;
    if (targets.size() != outputs.size() || values.size() != impl.approximation.parameters.size())
        throw internalError("CeresInverter::solve: one target per output and one value per parameter");
    std::vector<int> active;
    impl.prepared.assign(targets.size(), PreparedTarget{});
    for (std::size_t k = 0; k < targets.size(); ++k) {
        if (!targets[k].active) continue;
        if (!prepareTarget(targets[k], impl.options.rotationScaleCm, impl.prepared[k]))
            throw Error(fmt::format("CeresInverter: the target of {} is not usable", outputs[k].name));
        active.push_back(static_cast<int>(k));
    }
    auto& slot = impl.problems[active];
    if (!slot) slot = std::make_unique<CeresProblem>(impl.approximation, active);
    CeresProblem& p = *slot;
    p.workspace.setTargets(impl.prepared);
    for (std::size_t i = 0; i < values.size(); ++i) {
        const RigParameter& param = impl.approximation.parameters[i].parameter;
        p.x[i] = param.limited ? std::clamp(values[i], param.min, param.max) : values[i];
    }
    ceres::Solver::Summary summary;
    ceres::Solve(impl.ceresOptions, p.problem.get(), &summary);
    std::copy(p.x.begin(), p.x.end(), values.begin());
    CeresSolve result;
    result.converged = summary.termination_type == ceres::CONVERGENCE;
    result.iterations = summary.num_successful_steps + summary.num_unsuccessful_steps;
    result.initialCost = summary.initial_cost;
    result.finalCost = summary.final_cost;
    return result;
}

}  // namespace rig::bench
