function mo = check_multioutput(mo, allowed, fname)
%CHECK_MULTIOUTPUT The four aggregation names first, then those the function supports.
  dynval.internal.check_choice('multioutput', mo, ...
    {'pooled', 'raw_values', 'uniform_average', 'variance_weighted'});
  if ~any(strcmp(mo, allowed))
    quoted = cellfun(@(c) ['''' c ''''], allowed, 'UniformOutput', false);
    dynval.internal.param_error('multioutput', ['one of ' strjoin(quoted, ', ') ' for ' fname], mo);
  end
end
