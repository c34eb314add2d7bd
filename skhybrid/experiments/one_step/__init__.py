"""The one-step protocol: the paper's simulated systems (section 6).

The paper's windows, its model zoo scored one step ahead on the train,
interpolative and extrapolative sets (``_system``), a system's result
(``_result``), the paper's stochastic part (``_stochastic``), its claims
(``_claims``) and its report (``_report``). A change to the paper's protocol,
its zoo or its claims goes here.
"""
